"""The built frontend: hashed assets gzip-compressed with a one-year immutable cache; index.html no-cache."""

from fastapi.testclient import TestClient

from waamflow.api.app import create_app
from waamflow.settings import Settings


def test_assets_compressed_and_cached(tmp_path):
    dist = tmp_path / "dist"
    (dist / "assets").mkdir(parents=True)
    (dist / "index.html").write_text('<div id="root"></div><script src="/assets/index-abc123.js"></script>')
    js = "".join(f"export const v{i} = {i} * 2; // some bundle text\n" for i in range(2000)).encode()
    (dist / "assets" / "index-abc123.js").write_bytes(js)
    (dist / "assets" / "tiny-1.css").write_text("a{}")
    gdir = tmp_path / "graphs"
    gdir.mkdir()
    s = Settings(data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, static_dir=dist, workers=1)
    with TestClient(create_app(s)) as c:
        r = c.get("/assets/index-abc123.js", headers={"Accept-Encoding": "gzip"})
        assert r.status_code == 200
        assert r.headers["cache-control"] == "public, max-age=31536000, immutable"
        assert r.headers["content-encoding"] == "gzip"
        assert "javascript" in r.headers["content-type"]
        encoded = int(r.headers["content-length"])
        assert encoded < len(js) / 5, (encoded, len(js))
        assert r.content == js  # the client decodes: same bytes as the file
        # A client without gzip gets the plain file, still cacheable.
        plain = c.get("/assets/index-abc123.js", headers={"Accept-Encoding": "identity"})
        assert "content-encoding" not in plain.headers and int(plain.headers["content-length"]) == len(js)
        assert plain.headers["cache-control"].endswith("immutable")
        # Too small to gain from gzip: sent as is.
        tiny = c.get("/assets/tiny-1.css", headers={"Accept-Encoding": "gzip"})
        assert tiny.text == "a{}" and "content-encoding" not in tiny.headers
        assert c.get("/assets/missing.js").status_code == 404
        for path in ("/", "/index.html", "/some/route"):
            idx = c.get(path)
            assert idx.status_code == 200 and 'id="root"' in idx.text
            assert idx.headers["cache-control"] == "no-cache", path


def test_viewer_page_cached_like_the_hashed_assets(tmp_path):
    """#25 fault 11: viser's client page (~0.8 MB) was downloaded again on every visit to the 3D
    tab (viser sends no cache header). The app serves it under a content-hashed URL, immutable."""
    import hashlib
    from pathlib import Path

    import viser

    from waamflow.viewer.embed import client_root

    page = (client_root(Path(viser.__file__).parent / "client" / "build") / "index.html").read_bytes()
    assert b"wf-embedded" in page  # the page as the viewer serves it, with the embedding lines
    digest = hashlib.sha256(page).hexdigest()[:16]
    gdir = tmp_path / "graphs"
    gdir.mkdir()
    s = Settings(data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, workers=1)
    with TestClient(create_app(s)) as c:
        url = f"/viewer-client/{digest}/index.html"
        r = c.get(url, headers={"Accept-Encoding": "gzip"})
        assert r.status_code == 200
        assert r.headers["cache-control"] == "public, max-age=31536000, immutable"
        assert r.headers["content-encoding"] == "gzip"
        assert int(r.headers["content-length"]) < 0.9 * len(page)  # 668 of 819 kB: mostly inlined binary data
        assert r.content == page
        assert c.get(url, headers={"Accept-Encoding": "identity"}).content == page
        # another version's hash is not this page: 404, never cached
        old = c.get("/viewer-client/0000000000000000/index.html")
        assert old.status_code == 404 and old.headers["cache-control"] == "no-cache"
        # without a running viewer, health names no page
        assert c.get("/api/health").json()["viewer_page"] is None
