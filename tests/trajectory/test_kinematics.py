"""Pinocchio kinematics of the shipped arm and positioner; warnings by layer and section."""

import numpy as np
import pinocchio as pin
import pytest

from waamflow.core.model import Layer, LayerPaths, Layered, SectionPath
from waamflow.core.moves import flatten
from waamflow.trajectory import study
from waamflow.trajectory.kinematics import CellFrames, load_arm, resample, solve_path
from waamflow.trajectory.profile import ROBOTS_DIR, load_profile
from waamflow.trajectory.run import KinematicsOptions, simulate_program
from waamflow.trajectory.simulate import SimOptions

ARM = load_arm("kuka_kr150_2.urdf", tcp_offset_mm=(0.0, 0.0, 400.0))
KUKA = load_profile("kuka_kr100ha_krc2")


def test_home_pose_from_published_dimensions():
    """At A1..A6 = 0, −90, 90, 0, 90, 0 the flange points down at x = a1 + d4 (+d6... see below)."""
    data = ARM.model.createData()
    pin.framesForwardKinematics(ARM.model, data, ARM.home)
    flange = data.oMf[ARM.model.getFrameId("tool0")]
    # x: 0.35 + 1.1 (forearm) ; z: 0.75 + 1.25 (upper arm up) − 0.055 − 0.23 (flange down)
    assert flange.translation == pytest.approx([1.45, 0.0, 1.715], abs=1e-9)
    assert flange.rotation[:, 2] == pytest.approx([0, 0, -1], abs=1e-9)
    tcp = data.oMf[ARM.tcp]
    assert tcp.translation == pytest.approx([1.45, 0.0, 1.315], abs=1e-9)
    assert ARM.qd_max == pytest.approx(np.radians([105, 107, 114, 179, 172, 219]), rel=1e-3)


def test_resample_keeps_vertices():
    s, xyz, seg = resample(np.array([[0, 0, 0], [10, 0, 0], [10, 3, 0]], float), 4.0)
    assert s[-1] == pytest.approx(13.0)
    assert len(s) == 3 + 1 + 1  # ceil(10/4)=3, ceil(3/4)=1, + end point
    assert any(np.allclose(p, [10, 0, 0]) for p in xyz)


def test_ik_tracks_the_study_path():
    mv = study.planned("triangular", 40.0, angle_deg=45.0)
    k = solve_path(ARM, mv.points, mv.tool_axis, CellFrames(), step_mm=2.0)
    assert k.reach_err.max() < 1e-3  # mm
    assert k.sigma_min.min() > 0.05
    # continuity: neighbouring samples 2 mm apart never jump more than 1° in any joint
    assert np.degrees(np.abs(np.diff(k.q, axis=0))).max() < 1.0
    assert np.all(k.segment_cap > 1000.0)  # this small rectangle never hits joint speeds


def _moves(points, speed, key="bs1/A", layer=3):
    pts = np.asarray(points, float)
    m = len(pts) - 1
    sp = SectionPath(
        key=key, strategy="t", points=pts, arc=np.ones(m, bool), inside=np.ones(m, bool), speed=np.full(m, speed)
    )
    return flatten(Layered((LayerPaths(Layer(index=layer, z=float(pts[0, 2]), thickness=1.0), (sp,)),)))


def test_unreachable_target_warns_with_layer_and_section():
    mv = _moves([[0, 0, 50], [100, 0, 50], [3500, 0, 50]], 20.0)
    res = simulate_program(mv, KUKA, SimOptions(), KinematicsOptions())
    msgs = [w for w in res.warnings if "unreachable" in w[0]]
    assert msgs and msgs[0][1] == 3 and msgs[0][2] == "bs1/A"
    assert res.metrics["unreachable_stretches"] >= 1
    assert res.metrics["total_time_s"] > 0  # still simulated, no crash


def test_joint_speed_caps_path_speed():
    """A fast move close to the base turns A1 quickly: the path speed is capped by A1's 105°/s."""
    frames = CellFrames(base_xyz_mm=(-700.0, 0.0, -600.0))
    mv = _moves([[0, -200, 50], [0, 200, 50]], 2000.0)
    res = simulate_program(mv, KUKA, SimOptions(), KinematicsOptions(frames=frames, step_mm=10.0))
    cap = res.metrics["min_joint_speed_cap_mm_s"]
    # A1 turns about the base: |dq1/ds| ≈ 1/r with r ≈ 700 mm → cap ≈ 0.7 m · 1.83 rad/s ≈ 1283 mm/s
    assert 1000.0 < cap < 1400.0
    assert res.metrics["joint_speed_capped_segments"] == 1
    assert max(res.trace["speed"]) <= cap * 1.01
    assert any("joint speed" in w[0] for w in res.warnings)


def test_positioner_model():
    model = pin.buildModelFromUrdf(str(ROBOTS_DIR / "positioner_tilt_rotate.urdf"))
    data = model.createData()
    top = model.getFrameId("table_top")
    pin.framesForwardKinematics(model, data, np.array([np.pi / 2, 0.0]))
    # tilting 90° about x swings the table top (0.1 m above the axis at 0.8 m) to −y
    assert data.oMf[top].translation == pytest.approx([0.0, -0.1, 0.8], abs=1e-9)
    assert model.velocityLimit == pytest.approx([np.pi / 2, np.pi], rel=1e-4)


def test_smallest_singular_values_decide_as_the_svd_does():
    """sigma_min from J·Jᵀ's eigenvalues: where a figure depends on it (below SINGULAR_SIGMA, and
    the smallest value) it is the SVD's number to the bit; elsewhere within 1e-12 of it. Matrices
    from well-conditioned down to singular (a repeated row), some at SINGULAR_SIGMA itself."""
    from waamflow.trajectory.kinematics import SINGULAR_SIGMA, smallest_singular_values

    rng = np.random.default_rng(7)
    k = 4000
    U = np.linalg.qr(rng.normal(size=(k, 5, 5)))[0]
    V = np.linalg.qr(rng.normal(size=(k, 6, 6)))[0][:, :5, :]
    s = np.sort(rng.uniform(0.5, 3.0, size=(k, 5)), axis=1)[:, ::-1].copy()
    s[:, -1] = np.concatenate(
        [
            rng.uniform(0.02, 1.0, k - 1000),
            np.full(300, SINGULAR_SIGMA),  # at the threshold (to rounding)
            SINGULAR_SIGMA * (1 + rng.uniform(-1e-12, 1e-12, 300)),
            10.0 ** rng.uniform(-12, -2, 399),
            [0.0],
        ]
    )
    J = U @ (s[:, :, None] * V)
    J[-1, 4] = J[-1, 3]  # exactly singular
    want = np.linalg.svd(J, compute_uv=False)[:, -1]
    got = smallest_singular_values(J)
    assert got.shape == (k,)
    assert np.array_equal(got < SINGULAR_SIGMA, want < SINGULAR_SIGMA)
    assert np.count_nonzero(want < SINGULAR_SIGMA) > 400
    assert got.min() == want.min()
    assert np.max(np.abs(got - want)) < 1e-12
    exact = got == want
    assert 400 < np.count_nonzero(exact) < k  # the decided ones exact, the others not recomputed
    # the smallest value exact on a batch where every sample is far from near-singular
    far = J[: k - 1000]
    assert smallest_singular_values(far).min() == np.linalg.svd(far, compute_uv=False)[:, -1].min()
    assert smallest_singular_values(np.zeros((0, 5, 6))).shape == (0,)


def test_lapack_dposv_is_scipys_without_its_package_import():
    """kinematics.lapack_dposv solves as scipy.linalg.lapack.dposv does, to the bit, and in a fresh
    process it is found without importing scipy.linalg (0.2 s of CPU a run would pay for it)."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from waamflow.trajectory.kinematics import lapack_dposv\n"
        "import numpy as np\n"
        "A = np.array([[4.0, 1.0], [1.0, 3.0]]); b = np.array([[1.0, 0.5], [2.0, -1.0]])\n"
        "c, x, info = lapack_dposv()(A, b)\n"
        "print('scipy.linalg' in sys.modules, info, repr(x.tolist()))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split(" ", 2)
    assert out[0] == "False" and out[1] == "0"
    from scipy.linalg.lapack import dposv

    from waamflow.trajectory.kinematics import lapack_dposv

    A = np.array([[4.0, 1.0], [1.0, 3.0]])
    b = np.array([[1.0, 0.5], [2.0, -1.0]])
    assert out[2].strip() == repr(dposv(A, b)[1].tolist())
    rng = np.random.default_rng(3)
    for _ in range(200):
        J = rng.normal(size=(5, 6))
        M = J @ J.T + 1e-4 * np.eye(5)
        rhs = rng.normal(size=(5, 2))
        assert np.array_equal(lapack_dposv()(M, rhs)[1], dposv(M, rhs)[1])
