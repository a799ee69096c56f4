"""A tablet as its own process, for the fault-injection tests (SIGSTOP, floods, stalls).

    python tests/faults/tablet_proc.py PORT MODE

Modes (all on 127.0.0.1:PORT, the station's tablet server):

* ``speed`` - hello, answer pings, send ``speed`` (turn on the spot at 0.3 rad/s, with ``seq`` and ``t``) every
  100 ms, as the Tablet app's joystick does; SIGSTOP freezes it like a hung app;
* ``stall`` - like ``speed`` for 1 s; then the link stalls and 1 s of commands waits in a
  buffer, the app hangs for 1 s more, and the whole backlog is written at once (the newest
  command in it is 1 s old); then it goes quiet; prints ``burst`` when it wrote them;
* ``flood`` - no hello: writes speed commands as fast as the socket takes them, for ever.

Prints ``ready`` once connected. Plain sockets and the standard library only.
"""

from __future__ import annotations

import json
import selectors
import socket
import sys
import time


def _speed(seq: int, angular: float = 0.3) -> bytes:
    body = {"linear": 0.0, "angular": angular, "seq": seq, "t": round(time.monotonic(), 4)}
    return json.dumps({"speed": body}).encode() + b"\n"


def _answer_pings(sock: socket.socket, buffer: bytearray) -> None:
    try:
        chunk = sock.recv(65536)
    except BlockingIOError:
        return
    if not chunk:
        sys.exit(0)
    buffer.extend(chunk)
    *lines, rest = bytes(buffer).split(b"\n")
    buffer[:] = rest
    for line in lines:
        if line.startswith(b'{"ping"'):
            sock.sendall(json.dumps({"pong": json.loads(line)["ping"]}).encode() + b"\n")


def run_speed(sock: socket.socket, stall: bool) -> None:
    sock.sendall(b'{"hello": {"protocol": 1, "client": "fault-tablet"}}\n')
    sock.setblocking(False)
    selector = selectors.DefaultSelector()
    selector.register(sock, selectors.EVENT_READ)
    buffer = bytearray()
    print("ready", flush=True)
    seq, start, next_send = 0, time.monotonic(), time.monotonic()
    held: list[bytes] = []
    while True:
        for _ in selector.select(max(0.0, next_send - time.monotonic())):
            _answer_pings(sock, buffer)
        now = time.monotonic()
        if now < next_send:
            continue
        next_send += 0.1
        seq += 1
        message = _speed(seq)
        if not stall or now - start < 1.0:
            sock.setblocking(True)
            sock.sendall(message)
            sock.setblocking(False)
        elif now - start < 2.0:
            held.append(message)  # the link is stalled: the commands wait in a buffer
        elif now - start < 3.0:
            pass  # and the app hangs
        elif held:
            sock.setblocking(True)
            sock.sendall(b"".join(held))
            sock.setblocking(False)
            held.clear()
            print("burst", flush=True)


def run_flood(sock: socket.socket) -> None:
    blob = b"".join(
        json.dumps({"speed": {"linear": 0.3, "angular": 0.0}}).encode() for _ in range(2000)
    )
    print("ready", flush=True)
    while True:
        sock.sendall(blob)


def main() -> None:
    port, mode = int(sys.argv[1]), sys.argv[2]
    sock = socket.create_connection(("127.0.0.1", port), timeout=10.0)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    try:
        if mode == "flood":
            run_flood(sock)
        else:
            run_speed(sock, stall=mode == "stall")
    except (BrokenPipeError, ConnectionResetError):
        pass


if __name__ == "__main__":
    main()
