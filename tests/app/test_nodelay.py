"""``TCP_NODELAY`` on connections accepted from a socket bound as uvicorn's workers bind it."""

from __future__ import annotations

import asyncio
import socket

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
    assert asyncio.run(_accepted_nodelay(fix=False)) == 0  # what uvicorn's workers got
    assert asyncio.run(_accepted_nodelay(fix=True)) != 0
