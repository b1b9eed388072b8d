import numpy as np

from waamflow.program.orientation import abc_matrix, kuka_abc, quaternions, tool_frames

DOWN = np.array([[0.0, 0.0, -1.0]])


def test_vertical_torch():
    assert np.allclose(kuka_abc(tool_frames(DOWN, "x")), [[0.0, 90.0, 0.0]])
    assert np.allclose(quaternions(tool_frames(DOWN, "z")), [[0.0, 0.0, 1.0, 0.0]])


def test_frames_are_rotations_with_tool_axis_and_roundtrip():
    rng = np.random.default_rng(7)
    axes = rng.normal(size=(50, 3))
    axes[:, 2] = -np.abs(axes[:, 2]) - 0.2
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    for direction, col in (("x", 0), ("z", 2)):
        R = tool_frames(axes, direction)
        assert np.allclose(R[:, :, col], axes, atol=1e-12)
        assert np.allclose(np.einsum("nij,nik->njk", R, R), np.eye(3), atol=1e-12)
        assert np.allclose(np.linalg.det(R), 1.0)
        assert np.allclose(abc_matrix(kuka_abc(R)), R, atol=1e-9)
        q = quaternions(R)
        assert np.allclose(np.linalg.norm(q, axis=1), 1.0) and np.all(q[:, 0] >= 0)
        w, x, y, z = q.T  # rotate e_col by q and compare with the tool axis
        Rq = np.stack(
            [
                np.column_stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)]),
                np.column_stack([2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)]),
                np.column_stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)]),
            ],
            axis=2,
        )
        assert np.allclose(Rq, R, atol=1e-9)


def test_axis_parallel_to_reference():
    R = tool_frames(np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]), "z")
    assert np.allclose(R[:, :, 2], [[1, 0, 0], [-1, 0, 0]])
    assert np.allclose(np.linalg.det(R), 1.0)
