"""viser's stock web client, adjusted for embedding in the waamflow GUI.

The GUI shows the scene in an iframe with its own controls beside it, so inside the iframe
nothing may cover the scene: with `?embedded` in the URL the page hides viser's notification
stack (the "software WebGL rendering" / "WebGL unavailable" notices a headless or GPU-less
browser raises over the canvas). With `?view=<id>` (the GUI tab's 3D view) the page opens its
websocket at `<page>/?view=<id>` — viser's client takes its server from a `websocket` parameter,
which the script adds before the client starts — so the server knows which view the browser
client belongs to (`ViewerService`, one scene per view). The client files are viser's own, linked from a folder next to
them in the temp directory; only index.html gains a few lines of CSS and script.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
from pathlib import Path
from typing import Any, Iterator

EMBED_HEAD = (
    "<style>html.wf-embedded .mantine-Notifications-root{display:none!important}</style>"
    "<script>(function(){var q=new URLSearchParams(location.search);"
    "if(q.has('embedded'))document.documentElement.classList.add('wf-embedded');"
    "var v=q.get('view');if(v&&!q.has('websocket')){"
    "var u=location.href.split('?')[0].split('#')[0].replace(/^http/,'ws');if(!u.endsWith('/'))u+='/';"
    "q.set('websocket',u+'?view='+encodeURIComponent(v));"
    "history.replaceState(null,'',location.pathname+'?'+q.toString()+location.hash)}})()</script>"
)


def client_root(build: Path) -> Path:
    """A folder serving viser's build with the embed lines in index.html (made once per build)."""
    index = (build / "index.html").read_text(encoding="utf-8")
    tag = hashlib.sha256((index + EMBED_HEAD).encode()).hexdigest()[:12]
    root = Path(tempfile.gettempdir()) / f"waamflow-viser-client-{tag}"
    if (root / "index.html").is_file():
        return root
    tmp = Path(tempfile.mkdtemp(prefix=root.name + ".", dir=root.parent))
    for entry in build.iterdir():
        if entry.name != "index.html":
            (tmp / entry.name).symlink_to(entry.resolve(), target_is_directory=entry.is_dir())
    head = index.index("</head>")
    (tmp / "index.html").write_text(index[:head] + EMBED_HEAD + index[head:], encoding="utf-8")
    try:
        os.replace(tmp, root)  # atomic; a concurrent server may have made the same folder first
    except OSError:
        pass
    return root if (root / "index.html").is_file() else tmp


@contextlib.contextmanager
def embedded_client() -> Iterator[None]:
    """While active, a new ViserServer serves the embeddable client (viser builds its HTTP
    server from `infra.WebsockServer(http_server_root=...)` in its constructor)."""
    from viser import infra

    original = infra.WebsockServer

    def factory(*args: Any, **kwargs: Any) -> Any:
        build = kwargs.get("http_server_root")
        if build is not None and (Path(build) / "index.html").is_file():
            try:
                kwargs["http_server_root"] = client_root(Path(build))
            except OSError:  # read-only temp dir: serve the stock client
                pass
        return original(*args, **kwargs)

    # setattr: the module attribute viser's constructor looks up is swapped for a while (a class
    # name, which mypy will not let a plain assignment rebind)
    setattr(infra, "WebsockServer", factory)
    try:
        yield
    finally:
        setattr(infra, "WebsockServer", original)
