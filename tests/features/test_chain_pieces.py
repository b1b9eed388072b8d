"""`chain_pieces` joins the same pieces, in the same order, as the literal rule it replaced
(every join re-scanning every joint against every piece end: O(joints² × pieces); ezdxf's
recover01.dxf, ~3,000 walls a layer, spent 50 of its 240 s there)."""

import numpy as np
import pytest

from waamflow.features.chain import chain_pieces


def literal(pieces, joints, tol):
    """The rule as walls.py applied it before 2026-11-26."""
    pieces = [p for p in pieces]
    changed = True
    while changed:
        changed = False
        for jp in joints:
            at = [(k, e) for k, p in enumerate(pieces) for e in (0, -1) if np.hypot(*(p[e] - jp)) <= tol]
            if len(at) != 2 or at[0][0] == at[1][0]:
                continue
            (a, ea), (b, eb) = at
            pa = pieces[a] if ea == -1 else pieces[a][::-1]
            pb = pieces[b] if eb == 0 else pieces[b][::-1]
            pieces = [p for k, p in enumerate(pieces) if k not in (a, b)] + [np.vstack([pa, pb[1:]])]
            changed = True
            break
    return pieces


def _case(rng, n_nodes, n_pieces):
    """Pieces between random nodes of a small grid (so ends meet, three or more at some nodes,
    loops close), each with a random interior point; joints: a random subset of the nodes, shuffled,
    some nudged within the tolerance."""
    nodes = rng.integers(0, 6, size=(n_nodes, 2)).astype(float) * 10.0
    pieces = []
    for _ in range(n_pieces):
        i, j = rng.choice(n_nodes, 2)
        mid = (nodes[i] + nodes[j]) / 2 + rng.normal(0, 1, 2)
        pieces.append(np.array([nodes[i], mid, nodes[j]]))
    joints = [nodes[k] + rng.uniform(-0.04, 0.04, 2) for k in rng.permutation(n_nodes)[: max(1, n_nodes - 2)]]
    return pieces, joints


@pytest.mark.parametrize("seed", range(300))
def test_the_same_pieces_as_the_literal_rule(seed):
    rng = np.random.default_rng(seed)
    pieces, joints = _case(rng, int(rng.integers(2, 14)), int(rng.integers(1, 16)))
    want, got = literal(pieces, joints, 0.05), chain_pieces(pieces, joints, 0.05)
    assert len(got) == len(want)
    for a, b in zip(got, want):
        assert np.array_equal(a, b)


def test_a_long_chain_joins_into_one_piece():
    xs = np.arange(0, 2001, 1.0)
    pieces = [np.array([[x, 0.0], [x + 1.0, 0.0]]) for x in xs[:-1]][::-1]
    joints = [np.array([x, 0.0]) for x in xs[1:-1]]
    (one,) = chain_pieces(pieces, joints, 1e-6)
    assert len(one) == 2001 and {tuple(one[0]), tuple(one[-1])} == {(0.0, 0.0), (2000.0, 0.0)}
