"""A run reads and hashes an input file as few times as it can (issue #30: the bench vase's 50 MB
STL was read three times and hashed three times before its mesh was parsed): one read gives the
cache key's signature and the trace's sha256, the node's own read reuses that sha256."""

import hashlib
from pathlib import Path

from waamflow.engine import executor
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import load_recipe

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def test_the_mesh_file_is_read_twice_and_hashed_once_per_kind(monkeypatch):
    reads: list[str] = []
    real = executor.read_regular

    def counted(p, *a, **k):
        reads.append(Path(p).name)
        return real(p, *a, **k)

    monkeypatch.setattr(executor, "read_regular", counted)
    executor._FILE_SIGS.clear()
    path = GRAPHS / "mpp-cross.json"
    res = execute(build_graph(load_recipe(path)), resolver=FileResolver(path.parent), workers=1, preflight=False)
    assert reads.count("cross.stl") == 2  # the cache key's and trace's digests, the node's own read
    sha = hashlib.sha256((GRAPHS / "parts" / "cross.stl").read_bytes()).hexdigest()
    assert res.trace["inputs"]["parts/cross.stl"] == sha
    again = FileResolver(path.parent)
    assert again.sha256("parts/cross.stl") == sha and again.read_bytes("parts/cross.stl")
    assert again.read_hashes["parts/cross.stl"] == sha and reads.count("cross.stl") == 3  # memoised digests


def test_a_files_signature_is_the_first_half_of_its_sha256(monkeypatch, tmp_path):
    """One hash of a file's content gives both its signature (cache keys) and its sha256 (the
    trace): blake2b of the bench vase's 50 MB took 0.10 s of CPU beside sha256's 0.04 s. An
    attached file signs as the same file on disk."""
    from waamflow.engine.cache import bytes_signature

    data = (GRAPHS / "parts" / "cross.stl").read_bytes()
    (tmp_path / "cross.stl").write_bytes(data)
    sha = hashlib.sha256(data).hexdigest()
    executor._FILE_SIGS.clear()
    hashed: list[int] = []
    real = hashlib.sha256

    def counted(b=b""):
        hashed.append(len(b))
        return real(b)

    monkeypatch.setattr(executor.hashlib, "sha256", counted)
    on_disk = FileResolver(tmp_path)
    assert on_disk.signature("cross.stl") == sha[:32] and on_disk.sha256("cross.stl") == sha
    assert hashed == [len(data)]  # one hash of the content for both
    monkeypatch.undo()
    assert FileResolver(tmp_path, attachments={"cross.stl": data}).signature("cross.stl") == sha[:32]
    assert bytes_signature(data) == sha[:32] and bytes_signature(data + b"\0") != sha[:32]


def test_without_a_cache_a_large_file_is_hashed_beside_its_parsing(monkeypatch):
    """issue 30: a run with no cache to look the mesh node up in signs it after its run, and a large
    file it read is hashed in a thread meanwhile (hashlib frees the interpreter: the bench vase's
    50 MB sha256 beside its parsing): one read and one hash of the file, the same trace and the
    same signatures as a run with a cache."""
    import threading

    from waamflow.engine.cache import MemoryCache

    reads: list[str] = []
    real = executor.read_regular

    def counted(p, *a, **k):
        reads.append(Path(p).name)
        return real(p, *a, **k)

    hashers: list[str] = []
    real_sha = hashlib.sha256
    size = (GRAPHS / "parts" / "cross.stl").stat().st_size

    def sha_spy(b=b""):
        if len(b) == size:
            hashers.append(threading.current_thread().name)
        return real_sha(b)

    monkeypatch.setattr(executor, "read_regular", counted)
    monkeypatch.setattr(executor.hashlib, "sha256", sha_spy)
    monkeypatch.setattr(executor, "HASH_BESIDE_BYTES", 1000)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1")  # both runs' program headers carry the same date
    executor._FILE_SIGS.clear()
    path = GRAPHS / "mpp-cross.json"
    graph = build_graph(load_recipe(path))
    res = execute(graph, resolver=FileResolver(path.parent), workers=1, preflight=False)
    assert reads.count("cross.stl") == 1
    assert len(hashers) == 1 and hashers[0].startswith("waamflow-hash")
    sha = real_sha((GRAPHS / "parts" / "cross.stl").read_bytes()).hexdigest()
    assert res.trace["inputs"]["parts/cross.stl"] == sha
    executor._FILE_SIGS.clear()
    cached = execute(graph, resolver=FileResolver(path.parent), cache=MemoryCache(), workers=1, preflight=False)
    assert cached.signatures == res.signatures and len(res.signatures) >= 8
    assert cached.artifacts == res.artifacts


def test_a_path_the_system_cannot_open_is_an_input_file_error(tmp_path):
    """A file param of 5,000 characters (an API fuzz) failed the run as `OSError: [Errno 36] File
    name too long: '<the server's folder>/aaa…'`: a planning failure with the server's path in it.
    It is the input error a missing file is (exit 2, 4xx), with the reason, the path cut short."""
    import pytest

    from waamflow.engine.recipe import InputFileError

    r = FileResolver(tmp_path)
    for path in ("a" * 5000, "a" * 300 + "/part.stl"):
        assert r.exists(path) is False and r.signature(path) == "missing"
        with pytest.raises(InputFileError, match=r"cannot be opened: File name too long") as err:
            r.read_bytes(path)
        assert str(tmp_path) not in str(err.value) and len(str(err.value)) < 300
