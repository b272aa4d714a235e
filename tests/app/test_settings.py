"""Settings from the environment, and the configurations they refuse."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import ValidationError

from app.cgroup_limits import usable_cores
from app.settings import Settings


def test_defaults_and_environment(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    for name in ("HYDRODIAG_DATA_DIR", "HYDRODIAG_DATABASE_URL", "HYDRODIAG_OPEN_READS"):
        monkeypatch.delenv(name, raising=False)
    defaults = Settings()
    assert defaults.data_dir == Path("data") and defaults.open_reads is False
    assert defaults.url.database == str((Path("data") / "hydrodiag.db").resolve())
    assert defaults.is_sqlite
    monkeypatch.setenv("HYDRODIAG_DATA_DIR", str(tmp_path))
    monkeypatch.setenv("HYDRODIAG_OPEN_READS", "true")
    monkeypatch.setenv("HYDRODIAG_DATABASE_URL", "postgresql+psycopg://svc:Xk2f9Lq@db/hd")
    configured = Settings()
    assert configured.open_reads is True
    assert configured.url.get_backend_name() == "postgresql" and not configured.is_sqlite


@pytest.mark.parametrize(("url", "reason"), [
    ("postgresql://app:postgres@db.example/hd", "well-known default"),
    ("postgresql://app:changethis@db.example/hd", "well-known default"),
    ("sqlite://", "in-memory"),
    ("sqlite:///:memory:", "in-memory"),
    ("mysql://app:Xk2f9Lq@db/hd", "unsupported database"),
    ("not a url", "not a database URL"),
])
def test_insecure_or_unworkable_databases_are_refused(url: str, reason: str) -> None:
    with pytest.raises(ValidationError, match=reason):
        Settings(database_url=url)


def test_a_file_as_data_dir_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "file"
    path.write_text("")
    with pytest.raises(ValidationError, match="not a folder"):
        Settings(data_dir=path)


def test_serve_runs_one_worker_per_usable_core_unless_told(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("HYDRODIAG_WORKERS", raising=False)
    assert Settings().workers == min(usable_cores(), 64)  # tests/app/test_cgroup_limits.py
    monkeypatch.setenv("HYDRODIAG_WORKERS", "3")
    assert Settings().workers == 3
    assert Settings().diagnosis_processes == 1 and Settings().diagnosis_queue == 32


def test_a_misspelt_variable_is_named_with_the_setting_it_may_mean() -> None:
    """``HYDRODIAG_OPENREADS=true`` left open reads off without a word, and the start-up
    log stated no setting (an operator's pass)."""
    from app.settings import Settings, settings_line, unknown_variables

    env = {"HYDRODIAG_OPENREADS": "true", "HYDRODIAG_RATE_LIMIT": "5", "HYDRODIAG_PORT": "9",
           "HYDRODIAG_CACHE_DIR": "/tmp", "HYDRODIAG_SEEDS": "3", "HYDRODIAG_ZZZ": "1",
           "PATH": "/bin"}
    assert unknown_variables(env) == [
        "HYDRODIAG_OPENREADS (did you mean HYDRODIAG_OPEN_READS?)",
        "HYDRODIAG_RATE_LIMIT (did you mean HYDRODIAG_RATE_LIMIT_PER_MINUTE?)",
        "HYDRODIAG_ZZZ"]
    line = settings_line(Settings(database_url="postgresql+psycopg://hd:S3cret-pw@db/hd",
                                  open_reads=True, rate_limit_per_minute=60))
    assert "open reads on" in line and "rate limit 60 per key and minute" in line
    assert "S3cret-pw" not in line and "postgresql+psycopg://hd:***@db/hd" in line


@pytest.mark.parametrize("secret", ["secret", "changethis", "a", "x" * 31])
def test_a_weak_console_secret_is_refused(monkeypatch: pytest.MonkeyPatch, secret: str) -> None:
    """The console's login cookies are signed with it: "secret" was taken, and anyone who
    guessed it could forge a login (a design pass)."""
    monkeypatch.setenv("HYDRODIAG_CONSOLE_SECRET", secret)
    with pytest.raises(ValidationError, match="at least 32 characters"):
        Settings()


def test_the_console_secret_signs_the_console_cookie(monkeypatch: pytest.MonkeyPatch,
                                                     tmp_path: Path) -> None:
    """Set, it signs the cookie (two hosts with one secret share logins) and never shows in
    the settings' text; blank, a random one is kept in the data folder."""
    from app.console.web import _secret

    good = "k3Y-" + "9f" * 20
    monkeypatch.setenv("HYDRODIAG_CONSOLE_SECRET", f" {good} ")
    settings = Settings(data_dir=tmp_path)
    assert _secret(settings) == good.encode()
    assert good not in repr(settings) and good not in str(settings.model_dump())
    assert not (tmp_path / "console-secret").exists()
    monkeypatch.setenv("HYDRODIAG_CONSOLE_SECRET", "")
    blank = Settings(data_dir=tmp_path)
    assert blank.console_secret is None
    kept = _secret(blank)
    assert len(kept) == 64 and (tmp_path / "console-secret").read_bytes().strip() == kept
    assert _secret(Settings(data_dir=tmp_path)) == kept


def test_the_proxies_believed_are_addresses_or_networks(monkeypatch: pytest.MonkeyPatch) -> None:
    assert Settings().forwarded_allow_ips == "127.0.0.1,::1"  # uvicorn's own default
    monkeypatch.setenv("HYDRODIAG_FORWARDED_ALLOW_IPS", "10.0.0.5, 172.16.0.0/12,*")
    assert Settings().forwarded_allow_ips == "10.0.0.5,172.16.0.0/12,*"
    monkeypatch.setenv("HYDRODIAG_FORWARDED_ALLOW_IPS", "10.0.0.5,proxy.internal")
    with pytest.raises(ValidationError, match=r"'proxy\.internal' is not an address"):
        Settings()
