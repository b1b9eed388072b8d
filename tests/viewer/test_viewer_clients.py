"""Several browser clients watch the same scene: each websocket receives every scene node."""

import time


from viewer_fixtures import RECIPE, outputs


def scene_names_received(ws, seconds: float = 3.0) -> set[str]:
    """Decode viser's wire format (16-byte header, zstd msgpack, raw buffers) and collect the
    `name` of every scene message received within `seconds`."""
    import msgspec
    import zstandard

    names: set[str] = set()
    deadline = time.monotonic() + seconds
    dec = zstandard.ZstdDecompressor()
    while time.monotonic() < deadline:
        try:
            frame = ws.recv(timeout=0.5)
        except TimeoutError:
            if names:
                break
            continue
        size = int.from_bytes(frame[:8], "little")
        clen = int.from_bytes(frame[8:16], "little")
        payload = msgspec.msgpack.decode(dec.decompress(frame[16 : 16 + clen], max_output_size=size))
        for m in payload["messages"]:
            if isinstance(m.get("name"), str):
                names.add(m["name"])
    return names


def test_two_clients_receive_the_same_scene(viewer):
    import viser
    from websockets.sync.client import connect

    viewer.publish("k", RECIPE, outputs(3))
    ws_url = viewer.url.replace("http://", "ws://")
    clients = [connect(ws_url, max_size=None, subprotocols=[f"viser-v{viser.__version__}"]) for _ in range(2)]
    try:
        got = [scene_names_received(c) for c in clients]
        expected = {n for n in viewer.scene_names() if n.count("/") >= 4}
        for names in got:
            assert expected <= names
        assert "/graph/zone/toolpath/L0002" in got[0] and got[0] & expected == got[1] & expected
        # a later publish reaches both
        viewer.publish("k", RECIPE, outputs(4))
        for c in clients:
            assert "/graph/zone/toolpath/L0003" in scene_names_received(c)
    finally:
        for c in clients:
            c.close()
