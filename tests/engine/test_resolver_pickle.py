"""The run's FileResolver travels to the layer workers with every chunk (`parallel.run_chain`).
A large mesh read in a run without a cache is hashed in a thread beside the parse
(`FileResolver._hashing`: a Future, which holds a lock): pickling the resolver then failed with
"TypeError: cannot pickle '_thread.RLock' object" in the mask node's layers (nefertiti.obj,
100,000 triangles, `--no-cache`, 8 runs of 8)."""

import pickle

from waamflow.engine.executor import HASH_BESIDE_BYTES, FileResolver


def test_a_resolver_hashing_a_read_beside_still_pickles(tmp_path):
    data = bytes(range(256)) * (HASH_BESIDE_BYTES // 256 + 1)
    (tmp_path / "big.stl").write_bytes(data)
    res = FileResolver(tmp_path)
    res.hash_beside = True
    assert res.read_bytes("big.stl") == data
    assert "big.stl" in res._hashing  # the hash is under way (or done) in the thread

    copy = pickle.loads(pickle.dumps(res))  # what a layer worker gets

    assert copy.base_dir == res.base_dir
    assert copy.read_bytes("big.stl") == data  # the worker's copy still reads
    assert copy._hashing == {} and copy.hash_beside is False  # a worker hashes nothing beside
    import hashlib

    assert res.read_hashes["big.stl"] == hashlib.sha256(data).hexdigest()  # the run's own copy is intact
