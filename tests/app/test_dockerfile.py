"""The Dockerfile's own steps, followed without a container engine.

No container engine runs here, so this test reads the Dockerfile and does what it says in a
temporary folder that stands for the image's file system:

* ``COPY`` copies from the repository (skipping what ``.dockerignore`` names);
* ``RUN pip install ...`` runs in a fresh virtual environment with ``--no-deps`` added:
  the project is built and installed for real (with pip's build isolation, which fetches
  the build backend from the package index as ``docker build`` would), but its runtime
  dependencies come from the development environment, linked in by a ``.pth`` file,
  instead of being downloaded again.  (A venv made with ``--system-site-packages`` would
  see the base interpreter's packages, not the development venv's, hence the ``.pth``.)
  ``PIP_NO_CACHE_DIR`` is dropped so that pip may reuse its local cache;
* the other ``RUN`` steps may only create the user and the data folder (``useradd``,
  ``mkdir``, ``chown``...): folders are made, user changes are skipped;
* ``CMD`` is started from the final ``WORKDIR`` with the ``ENV`` values, except where the
  data folder, host and port must point into the temporary folder;
* the ``HEALTHCHECK`` command itself is run until it succeeds.

The installed package then migrates a new store and answers ``/health`` and ``/ready``
from the virtual environment, away from the source tree: package data (the migrations)
and the entry point work as installed.
"""

from __future__ import annotations

import fnmatch
import json
import os
import shlex
import shutil
import socket
import subprocess
import sys
import sysconfig
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import httpx
import pytest

from tests.app.conftest import first_api_key

REPO = Path(__file__).resolve().parents[2]
DOCKERFILE = REPO / "Dockerfile"
SETUP_COMMANDS = {"useradd", "groupadd", "adduser", "addgroup", "mkdir", "chown", "chmod"}
STARTUP_TIMEOUT_S = 90.0


@dataclass
class Recipe:
    """What the Dockerfile says, in order."""

    base: str = ""
    env: dict[str, str] = field(default_factory=dict)
    steps: list[tuple[str, str, str]] = field(default_factory=list)  # (kind, workdir, args)
    user: str = "root"
    workdir: str = "/"
    volumes: list[str] = field(default_factory=list)
    exposed: list[str] = field(default_factory=list)
    healthcheck: list[str] = field(default_factory=list)
    cmd: list[str] = field(default_factory=list)


def _instructions(text: str) -> list[tuple[str, str]]:
    lines, current = [], ""
    for raw in text.splitlines():
        line = raw.strip()
        if not current and (not line or line.startswith("#")):
            continue
        if line.endswith("\\"):
            current += line[:-1] + " "
            continue
        current += line
        keyword, _, rest = current.partition(" ")
        lines.append((keyword.upper(), rest.strip()))
        current = ""
    return lines


def parse_dockerfile(text: str) -> Recipe:
    """Read the instructions this test knows; fail on any other."""
    recipe = Recipe()
    for keyword, rest in _instructions(text):
        if keyword == "FROM":
            recipe.base = rest
        elif keyword == "ENV":
            for pair in shlex.split(rest):
                name, _, value = pair.partition("=")
                recipe.env[name] = value
        elif keyword == "WORKDIR":
            recipe.workdir = str(PurePosixPath(recipe.workdir) / rest)
        elif keyword in {"COPY", "RUN"}:
            recipe.steps.append((keyword, recipe.workdir, rest))
        elif keyword == "USER":
            recipe.user = rest
        elif keyword == "VOLUME":
            recipe.volumes = json.loads(rest) if rest.startswith("[") else rest.split()
        elif keyword == "EXPOSE":
            recipe.exposed = rest.split()
        elif keyword == "HEALTHCHECK":
            recipe.healthcheck = json.loads(rest[rest.index("CMD") + 3:].strip())
        elif keyword == "CMD":
            recipe.cmd = json.loads(rest)
        else:
            raise AssertionError(f"test_dockerfile does not know {keyword}; teach it")
    return recipe


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _dockerignore() -> Callable[[str, list[str]], set[str]]:
    """``shutil.copytree`` filter for ``.dockerignore``: ``**/x`` at any depth, else from the
    root of the build context (the repository)."""
    anywhere, from_root = [], []
    for line in (REPO / ".dockerignore").read_text().splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            (anywhere if line.startswith("**/") else from_root).append(line.removeprefix("**/"))

    def ignored(folder: str, names: list[str]) -> set[str]:
        relative = Path(folder).resolve().relative_to(REPO)
        return {
            name for name in names
            if any(fnmatch.fnmatch(name, p) for p in anywhere)
            or any(fnmatch.fnmatch(str(relative / name), p) for p in from_root)
        }

    return ignored


class Image:
    """A folder standing for the image's file system, with a venv as its Python."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.venv = root / "venv"
        subprocess.run([sys.executable, "-m", "venv", str(self.venv)], check=True)
        purelib = sysconfig.get_paths()["purelib"]
        site = next(self.venv.glob("lib/python*/site-packages"))
        (site / "_hydrodiag_dev_env.pth").write_text(purelib + "\n")

    def path(self, container_path: str) -> Path:
        return self.root / "fs" / PurePosixPath(container_path).relative_to("/")

    def program(self, name: str) -> str:
        return str(self.venv / "bin" / name) if (self.venv / "bin" / name).exists() else name

    def copy(self, workdir: str, args: str) -> None:
        *sources, target = shlex.split(args)
        destination = PurePosixPath(workdir) / target
        ignore = _dockerignore()
        for source in sources:
            origin = REPO / source
            assert origin.exists(), f"COPY {source}: not in the repository"
            if origin.is_dir():
                shutil.copytree(origin, self.path(str(destination)), ignore=ignore,
                                dirs_exist_ok=True)
            else:
                target_dir = self.path(str(destination))
                target_dir.mkdir(parents=True, exist_ok=True)
                shutil.copy2(origin, target_dir / origin.name)

    def run(self, workdir: str, args: str, env: dict[str, str]) -> None:
        for command in args.split("&&"):
            words = shlex.split(command)
            if words[:2] == ["pip", "install"]:
                cwd = self.path(workdir)
                done = subprocess.run([str(self.venv / "bin" / "python"), "-m", "pip",
                                       "install", "--no-deps", *words[2:]],
                                      cwd=cwd, env=env, capture_output=True, text=True,
                                      check=False)
                if done.returncode != 0:
                    pytest.fail(f"RUN {command.strip()} failed:\n{done.stdout}{done.stderr}")
            elif words[0] == "mkdir":
                for folder in (w for w in words[1:] if not w.startswith("-")):
                    self.path(folder).mkdir(parents=True, exist_ok=True)
            else:
                assert words[0] in SETUP_COMMANDS, f"RUN {words[0]}: teach test_dockerfile"


def test_dockerfile_promises() -> None:
    recipe = parse_dockerfile(DOCKERFILE.read_text())
    assert recipe.base.startswith("python:") and recipe.base.endswith("-slim")
    assert recipe.user not in {"root", "0"}
    assert recipe.volumes == [recipe.env["HYDRODIAG_DATA_DIR"]]
    assert recipe.exposed == [recipe.env["HYDRODIAG_PORT"]]
    assert recipe.env["HYDRODIAG_HOST"] == "0.0.0.0"
    assert any(word.endswith("/health") or "/health" in word for word in recipe.healthcheck)
    assert recipe.cmd[:2] == ["hydrodiag", "serve"]


def test_the_image_steps_install_and_serve(tmp_path: Path) -> None:
    recipe = parse_dockerfile(DOCKERFILE.read_text())
    image = Image(tmp_path)
    build_env = os.environ | recipe.env
    build_env.pop("PIP_NO_CACHE_DIR", None)
    for kind, workdir, args in recipe.steps:
        if kind == "COPY":
            image.copy(workdir, args)
        else:
            image.run(workdir, args, build_env)

    port = str(_free_port())
    data_dir = image.path(recipe.env["HYDRODIAG_DATA_DIR"])
    run_env = os.environ | recipe.env | {
        "HYDRODIAG_DATA_DIR": str(data_dir), "HYDRODIAG_HOST": "127.0.0.1",
        "HYDRODIAG_PORT": port,
    }
    run_env.pop("HYDRODIAG_DATABASE_URL", None)
    run_env.pop("PYTHONPATH", None)
    cwd = image.path(recipe.workdir)
    cwd.mkdir(parents=True, exist_ok=True)
    where = subprocess.run([image.program("python"), "-c", "import app; print(app.__file__)"],
                           cwd=cwd, env=run_env, capture_output=True, text=True, check=True)
    assert Path(where.stdout.strip()).is_relative_to(image.venv), where.stdout

    server = subprocess.Popen([image.program(recipe.cmd[0]), *recipe.cmd[1:]], cwd=cwd,
                              env=run_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True)
    try:
        healthcheck = [image.program(recipe.healthcheck[0]), *recipe.healthcheck[1:]]
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while subprocess.run(healthcheck, cwd=cwd, env=run_env, capture_output=True,
                             check=False).returncode != 0:
            if server.poll() is not None:
                output = server.stdout.read() if server.stdout else ""
                pytest.fail(f"the CMD exited with {server.returncode}:\n{output}")
            if time.monotonic() > deadline:
                pytest.fail("the HEALTHCHECK did not pass in time")
            time.sleep(0.2)
        # alive is not ready: every worker warms its rigs and diagnosis process first
        while (ready := httpx.get(f"http://127.0.0.1:{port}/ready", timeout=10)
               ).status_code == 503 and time.monotonic() < deadline:
            time.sleep(0.2)
        assert ready.json()["status"] == "ready"
        assert (data_dir / "hydrodiag.db").exists()
    finally:
        server.terminate()
        output, _ = server.communicate(timeout=30)
    first_api_key(data_dir, output)
