"""A forked run or preview process closes the server's TCP sockets it inherited (a preview worker
holding a copy of a browser connection the server closed kept it open: the browser's next request
on it waited for good, and the GUI never showed the run's end) and keeps its own pipes."""

import multiprocessing as mp
import os
import socket

from waamflow.api.tree_memory import close_inherited_network_sockets


def _child(conn, fds):
    closed = close_inherited_network_sockets()
    still = {name: _is_open(fd) for name, fd in fds.items()}
    conn.send((closed, still))


def _is_open(fd: int) -> bool:
    try:
        os.fstat(fd)
        return True
    except OSError:
        return False


def test_forked_child_closes_tcp_sockets_and_keeps_unix_ones():
    listener = socket.create_server(("127.0.0.1", 0))
    client = socket.create_connection(listener.getsockname())
    accepted, _ = listener.accept()
    a, b = socket.socketpair()
    r, w = os.pipe()
    try:
        fds = {
            "listener": listener.fileno(),
            "client": client.fileno(),
            "accepted": accepted.fileno(),
            "pair": a.fileno(),
            "pipe": r,
        }
        parent, child = mp.get_context("fork").Pipe()
        p = mp.get_context("fork").Process(target=_child, args=(child, fds))
        p.start()
        closed, still = parent.recv()
        p.join(10)
        assert closed >= 3
        assert still == {"listener": False, "client": False, "accepted": False, "pair": True, "pipe": True}
        # the parent's own sockets are untouched: the connection still carries data
        client.sendall(b"x")
        assert accepted.recv(1) == b"x"
    finally:
        for s in (listener, client, accepted, a, b):
            s.close()
        os.close(r)
        os.close(w)
