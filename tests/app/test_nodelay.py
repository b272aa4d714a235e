"""``TCP_NODELAY`` on connections accepted from a socket bound as uvicorn's workers bind it."""

from __future__ import annotations

import asyncio
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from app.nodelay import set_nodelay


class _Probe(asyncio.Protocol):
    def __init__(self, seen: list[int], fix: bool) -> None:
        self.seen, self.fix = seen, fix

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        if self.fix:
            set_nodelay(transport)
        sock = transport.get_extra_info("socket")
        self.seen.append(sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY))
        transport.close()


async def _accepted_nodelay(fix: bool) -> int:
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)  # proto 0, as bind_socket
    listener.bind(("127.0.0.1", 0))
    listener.listen()
    seen: list[int] = []
    loop = asyncio.get_running_loop()
    server = await loop.create_server(lambda: _Probe(seen, fix), sock=listener)
    port = listener.getsockname()[1]
    _, writer = await asyncio.open_connection("127.0.0.1", port)
    for _ in range(200):
        if seen:
            break
        await asyncio.sleep(0.01)
    writer.close()
    server.close()
    await server.wait_closed()
    return seen[0]


def test_accepted_socket_of_a_proto0_listener_lacks_nodelay_unless_set() -> None:
    # asyncio's own loop whatever the policy: an older uvicorn (0.27) sets uvloop's policy for the
    # whole process when serving (an earlier test's server), and uvloop sets TCP_NODELAY itself
    for fix, nodelay in ((False, False), (True, True)):  # without the fix: what workers got
        with asyncio.Runner(loop_factory=asyncio.SelectorEventLoop) as runner:
            assert bool(runner.run(_accepted_nodelay(fix=fix))) is nodelay


@contextmanager
def _serving(app: Any) -> Iterator[int]:
    """``app`` served by uvicorn with :class:`app.nodelay.NoDelayHttpToolsProtocol` on a
    free local port, in a thread; the port."""
    import threading
    import time

    import uvicorn

    from app import nodelay

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, lifespan="off",
                                           http=nodelay.NoDelayHttpToolsProtocol,
                                           log_level="error"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    try:
        for _ in range(200):
            if server.started:
                break
            time.sleep(0.02)
        yield port
    finally:
        server.should_exit = True
        thread.join(timeout=10)


def test_a_connection_that_sends_nothing_is_closed(monkeypatch: pytest.MonkeyPatch) -> None:
    """A connection that never sent a request held its descriptor for ever, and 600 of
    them left /health unanswered at the open-file limit, no key needed (an SRE pass): it is
    closed after FIRST_REQUEST_S, as is one whose request head stops half way; one that
    asks in time is answered."""
    from app import nodelay

    monkeypatch.setattr(nodelay, "FIRST_REQUEST_S", 0.3)

    async def app(scope: dict, receive: object, send: object) -> None:  # type: ignore[type-arg]
        if scope["type"] != "http":
            return
        await send({"type": "http.response.start", "status": 200, "headers": []})  # type: ignore[operator]
        await send({"type": "http.response.body", "body": b"ok"})  # type: ignore[operator]

    with _serving(app) as port:
        silent = socket.create_connection(("127.0.0.1", port))
        silent.settimeout(5.0)
        assert silent.recv(1) == b""  # closed by the server, not by the timeout above
        silent.close()
        # one that sends a byte, or half a head, and stops is closed too (a verification
        # pass: it stayed open)
        for sent in (b"G", b"GET / HTTP/1.1\r\nHost: x\r\n"):
            partial = socket.create_connection(("127.0.0.1", port))
            partial.settimeout(5.0)
            partial.sendall(sent)
            assert partial.recv(1) == b"", sent
            partial.close()
        asking = socket.create_connection(("127.0.0.1", port))
        asking.settimeout(5.0)
        asking.sendall(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
        assert asking.recv(1024).startswith(b"HTTP/1.1 200")
        asking.close()


def test_a_body_that_comes_too_slowly_is_cut_and_one_in_time_is_read(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A body sent a byte at a time held its connection for as long as its client liked
    (an SRE pass left it to a proxy): past BODY_GRACE_S plus what came at MIN_BODY_RATE
    the connection is closed; a whole body sent in time, and one the service is slow to
    read (it waits before reading), are answered."""
    import time

    from app import nodelay

    monkeypatch.setattr(nodelay, "BODY_GRACE_S", 0.4)
    monkeypatch.setattr(nodelay, "MIN_BODY_RATE", 1e6)

    async def app(scope: dict, receive: Any, send: Any) -> None:  # type: ignore[type-arg]
        if scope["type"] != "http":
            return
        if scope["path"] == "/late":   # the service waits before it reads
            await asyncio.sleep(1.5)
        body = b""
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return
            body += message.get("body", b"")
            if not message.get("more_body"):
                break
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": str(len(body)).encode()})

    head = b"POST /%s HTTP/1.1\r\nHost: x\r\nContent-Length: %d\r\n\r\n"
    with _serving(app) as port:
        # what came buys time, what was declared does not: a 10 MB Content-Length bought
        # 34 min at 4 KiB/s (a verification pass)
        for declared in (100, 10_000_000):
            slow = socket.create_connection(("127.0.0.1", port))
            slow.settimeout(5.0)
            slow.sendall(head % (b"slow", declared) + b"x")
            started = time.perf_counter()
            assert slow.recv(1) == b"", declared   # closed by the server after 0.4 s
            assert time.perf_counter() - started < 3.0, declared
            slow.close()
        # in time; and 200 kB the service leaves unread for 1.5 s (its buffer fills and
        # it stops reading: that wait is not the client's)
        for path, size in ((b"whole", 100), (b"late", 200_000)):
            whole = socket.create_connection(("127.0.0.1", port))
            whole.settimeout(5.0)
            whole.sendall(head % (path, size) + b"y" * (size - 40))
            time.sleep(0.2)
            whole.sendall(b"y" * 40)
            answer = b""
            while not answer.endswith(b"0\r\n\r\n"):
                chunk = whole.recv(4096)
                assert chunk, (path, answer)
                answer += chunk
            assert answer.startswith(b"HTTP/1.1 200"), path
            assert f"\r\n{size}\r\n".encode() in answer, (path, answer)
            whole.close()
