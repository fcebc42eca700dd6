"""LaFAN1's in-betweening measures (scripts/lafan1_metrics.py) and the
benchmark script's forward kinematics and queries (scripts/inbetween-benchmark:
methods' flags, --strict-keys' excerpts).

Run by Debian's Python 3 with numpy and pytest (scripts/setup); CTest runs it
as scripts.test_inbetween_metrics (tests/CMakeLists.txt). Without numpy the
whole file is skipped. Every fast (numpy) form is checked against a slow
loop written here from the reference code's definitions
(ubisoft/ubisoft-laforge-animation-dataset, lafan1/benchmarks.py, utils.py,
extract.py), and each measure on small hand-made cases where the reference
definition and the project's former one differ.
"""
import importlib.util
import math
import os
import sys
from importlib.machinery import SourceFileLoader

import pytest

np = pytest.importorskip("numpy")

SCRIPTS = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "scripts"))
sys.path.insert(0, SCRIPTS)
import lafan1_metrics as lm  # noqa: E402


def rng(seed=1):
    return np.random.default_rng(seed)


def random_quats(shape, seed=1):
    q = rng(seed).normal(size=shape + (4,))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def axis_quat(axis, angle):
    """(w, x, y, z) of a rotation by `angle` radians about a unit axis."""
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * np.asarray(axis, float)])


def quat_to_matrix(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


# ------------------------------------------------------- slow references ----
def slow_npss(gt, pred, real_part=True):
    """NPSS by loops: DFT by its definition, power the square of the real part
    (or the squared magnitude), cumulative sums, L1 distance, the average
    weighted by the ground truth's total power over all sequences and
    features."""
    num = den = 0.0
    b_n, t_n, d_n = gt.shape
    for b in range(b_n):
        for d in range(d_n):
            spectra = []
            for x in (gt[b, :, d], pred[b, :, d]):
                power = []
                for k in range(t_n):
                    re = sum(x[n] * math.cos(2 * math.pi * k * n / t_n) for n in range(t_n))
                    im = -sum(x[n] * math.sin(2 * math.pi * k * n / t_n) for n in range(t_n))
                    power.append(re * re if real_part else re * re + im * im)
                spectra.append(power)
            g, p = spectra
            gs, ps = sum(g), sum(p)
            cg = cp = emd = 0.0
            for k in range(t_n):
                cg += g[k] / gs
                cp += p[k] / ps
                emd += abs(cp - cg)
            num += emd * gs
            den += gs
    return num / den


def slow_l2q(gt, pred):
    total, count = 0.0, 0
    for b in range(gt.shape[0]):
        for t in range(gt.shape[1]):
            s = 0.0
            for j in range(gt.shape[2]):
                for c in range(4):
                    s += (pred[b, t, j, c] - gt[b, t, j, c]) ** 2
            total += math.sqrt(s)
            count += 1
    return total / count


def slow_l2p(gt, pred, mean, std):
    """The reference's form: both normalised by (x - mean) / std, then the
    norm of the difference."""
    total, count = 0.0, 0
    for b in range(gt.shape[0]):
        for t in range(gt.shape[1]):
            s = 0.0
            for j in range(gt.shape[2]):
                for c in range(3):
                    i = 3 * j + c
                    s += ((pred[b, t, j, c] - mean[i]) / std[i]
                          - (gt[b, t, j, c] - mean[i]) / std[i]) ** 2
            total += math.sqrt(s)
            count += 1
    return total / count


def slow_continuous(q):
    q = [list(map(list, frame)) for frame in q]
    for t in range(1, len(q)):
        for j in range(len(q[t])):
            if sum(a * b for a, b in zip(q[t][j], q[t - 1][j])) < 0:
                q[t][j] = [-a for a in q[t][j]]
    return np.array(q)


def slow_train_stats(clips, root, window, offset, n_past):
    rows = []
    for pos, forward in clips:
        i = 0
        while i + window < len(pos):
            cx = sum(pos[i + k][root][0] for k in range(window)) / window
            cz = sum(pos[i + k][root][2] for k in range(window)) / window
            f = forward[i + n_past - 1]
            n = math.hypot(f[0], f[2])
            c, s = f[0] / n, f[2] / n  # the turn taking (c, s) in (x, z) onto +X
            for k in range(window):
                row = []
                for p in pos[i + k]:
                    x, y, z = p[0] - cx, p[1], p[2] - cz
                    row += [c * x + s * z, y, -s * x + c * z]
                rows.append(row)
            i += offset
    rows = np.array(rows)
    return rows.mean(axis=0), rows.std(axis=0), len(rows) // window


# --------------------------------------------------------- invalid input ----
def test_invalid_inputs_raise_clear_errors():
    q = random_quats((1, 3, 2))
    with pytest.raises(ValueError, match="shapes differ"):
        lm.l2q(q, q[:, :2])
    with pytest.raises(ValueError, match="empty"):
        lm.l2q(np.zeros((1, 0, 2, 4)), np.zeros((1, 0, 2, 4)))
    with pytest.raises(ValueError, match="last dimension of 4"):
        lm.l2q(q[..., :3], q[..., :3])
    p = rng().normal(size=(1, 3, 2, 3))
    with pytest.raises(ValueError, match="shapes differ"):
        lm.l2p(p, p[:, :, :1], np.ones(6))
    with pytest.raises(ValueError, match="6"):
        lm.l2p(p, p, np.ones(5))
    with pytest.raises(ValueError, match="no spread"):
        lm.l2p(p, p, np.array([1, 1, 0, 1, 1, 1.0]))
    with pytest.raises(ValueError, match="not finite"):
        lm.l2p(p, np.full_like(p, np.nan), np.ones(6))
    with pytest.raises(ValueError, match="shapes differ"):
        lm.npss(np.ones((1, 4, 2)), np.ones((1, 5, 2)))
    with pytest.raises(ValueError, match="empty"):
        lm.npss(np.ones((1, 0, 2)), np.ones((1, 0, 2)))
    with pytest.raises(ValueError, match="3 dimensions"):
        lm.npss(np.ones((4, 2)), np.ones((4, 2)))
    with pytest.raises(ValueError, match="expected"):
        lm.quat_continuous(np.ones(4))
    with pytest.raises(ValueError, match="shapes differ"):
        lm.quat_continuous(random_quats((3, 2)), first=random_quats((3,)))
    with pytest.raises(ValueError, match="no training window"):
        lm.train_stats([(np.zeros((50, 2, 3)), np.ones((50, 3)))], root=0)  # 50 frames: none
    with pytest.raises(ValueError, match="joints"):
        lm.train_stats([(np.zeros((6, 2, 3)), np.ones((6, 3))),
                        (np.zeros((6, 3, 3)), np.ones((6, 3)))], root=0, window=4, offset=2,
                       n_past=2)
    with pytest.raises(ValueError, match="no transition frame"):
        rot = np.tile(np.eye(3), (2, 1, 1, 1))
        lm.window_measures(np.zeros((2, 1, 3)), rot, np.zeros((2, 1, 3)), rot, [-1], 0, [0],
                           np.ones(3))


# ---------------------------------------------------------------- NPSS ----
def test_npss_equals_a_loop_over_frequencies():
    gen = rng(3)
    gt, pred = gen.normal(size=(3, 7, 5)), gen.normal(size=(3, 7, 5))
    assert lm.npss(gt, pred) == pytest.approx(slow_npss(gt, pred), rel=1e-12, abs=1e-15)


def test_npss_squares_the_real_part_not_the_magnitude():
    # x = (0, 1, 0, 0): X_k = exp(-i pi k / 2) = 1, -i, -1, i. The real part's
    # power is (1, 0, 1, 0), the magnitude's (1, 1, 1, 1). The prediction
    # (1, 0, 0, 0) has X_k = 1 for all k: power (1, 1, 1, 1) either way.
    # Real part: cumulative (.5, .5, 1, 1) against (.25, .5, .75, 1): 0.5.
    # Magnitude: the same flat spectrum: 0.
    gt = np.array([0.0, 1, 0, 0]).reshape(1, 4, 1)
    pred = np.array([1.0, 0, 0, 0]).reshape(1, 4, 1)
    assert lm.npss(gt, pred) == pytest.approx(0.5, abs=1e-12)
    assert lm.npss_magnitude(gt[0], pred[0]) == pytest.approx(0.0, abs=1e-12)
    assert slow_npss(gt, pred, real_part=False) == pytest.approx(0.0, abs=1e-12)
    # on a signal whose FFT has imaginary parts, the two forms differ
    gen = rng(4)
    g, p = gen.normal(size=(1, 9, 3)), gen.normal(size=(1, 9, 3))
    assert np.abs(np.imag(np.fft.fft(g, axis=1))).max() > 0.1
    real, magnitude = lm.npss(g, p), lm.npss_magnitude(g[0], p[0])
    assert real == pytest.approx(slow_npss(g, p), rel=1e-12)
    assert magnitude == pytest.approx(slow_npss(g, p, real_part=False), rel=1e-12)
    assert abs(real - magnitude) > 1e-3


def test_npss_weights_by_power_over_all_sequences():
    # Sequence A: the case above (distance 0.5, ground-truth power 1 + 1 = 2).
    # Sequence B: (10, 0, 0, 0) predicted exactly (distance 0, power 4 x 100).
    # One power-weighted figure: (0.5 * 2 + 0 * 400) / 402; a mean of
    # per-sequence figures would be 0.25.
    gt = np.array([[0.0, 1, 0, 0], [10.0, 0, 0, 0]]).reshape(2, 4, 1)
    pred = np.array([[1.0, 0, 0, 0], [10.0, 0, 0, 0]]).reshape(2, 4, 1)
    assert lm.npss(gt, pred) == pytest.approx(1.0 / 402, rel=1e-12)
    emd, power = lm.npss_terms(gt, pred)
    assert emd[:, 0] == pytest.approx([0.5, 0.0], abs=1e-12)
    assert power[:, 0] == pytest.approx([2.0, 400.0], rel=1e-12)


def test_npss_edge_cases():
    gen = rng(5)
    g = gen.normal(size=(2, 6, 3))
    assert lm.npss(g, g) == pytest.approx(0.0, abs=1e-12)
    assert lm.npss(g, 3.0 * g) == pytest.approx(0.0, abs=1e-12)  # spectra are normalised
    # a ground-truth feature with no power has weight 0: the others decide
    g2, p2 = g.copy(), gen.normal(size=g.shape)
    g2[:, :, 1] = 0.0
    keep = [0, 2]
    assert lm.npss(g2, p2) == pytest.approx(slow_npss(g2[:, :, keep], p2[:, :, keep]), rel=1e-12)
    with pytest.raises(ValueError, match="no power"):
        lm.npss(g, np.zeros_like(g))
    with pytest.raises(ValueError, match="no feature has power"):
        lm.npss(np.zeros_like(g), g)


# ----------------------------------------------------------------- L2Q ----
def test_quat_continuous_equals_a_loop():
    q = random_quats((9, 3), seed=6)
    flips = rng(7).choice([-1.0, 1.0], size=(9, 3, 1))
    assert np.array_equal(lm.quat_continuous(q * flips), slow_continuous(q * flips))
    out = lm.quat_continuous(q * flips)
    assert np.all(np.sum(out[1:] * out[:-1], -1) >= 0)


def test_l2q_equals_a_loop():
    gt, pred = random_quats((2, 5, 3), seed=8), random_quats((2, 5, 3), seed=9)
    assert lm.l2q(gt, pred) == pytest.approx(slow_l2q(gt, pred), rel=1e-12)


def test_l2q_continuity_removes_a_sign_flip_mid_sequence():
    # A joint turning 10 degrees a frame about z; the prediction is the same
    # rotations with the sign flipped from frame 3 on (as a matrix-to-quaternion
    # conversion may give). Made continuous from the ground truth's first frame,
    # it is the ground truth: L2Q 0. Not made continuous, the flipped frames
    # cost |q - (-q)| = 2 each: 2 * 4 / 7.
    gt = np.array([[axis_quat([0, 0, 1], math.radians(10 * t))] for t in range(7)])
    pred = gt.copy()
    pred[3:] *= -1
    assert lm.l2q(gt[None], pred[None]) == pytest.approx(2.0 * 4 / 7, rel=1e-12)
    fixed = lm.quat_continuous(pred, first=gt[0])
    assert lm.l2q(gt[None], fixed[None]) == pytest.approx(0.0, abs=1e-12)
    # every frame flipped: the context frame takes the ground truth's sign
    assert np.array_equal(lm.quat_continuous(-gt, first=gt[0]), gt)
    assert np.array_equal(lm.quat_continuous(-gt), -gt)


def test_l2q_does_not_align_signs_to_the_ground_truth():
    # The ground truth turns a joint +theta about z, the prediction -theta,
    # theta from 0 to 170 degrees. Continuous paths from the same start:
    # q_gt = (cos theta/2, 0, 0, sin theta/2), q_pred = (cos theta/2, 0, 0,
    # -sin theta/2), |q_pred - q_gt| = 2 sin(theta/2). Aligned to the ground
    # truth (the former form) the error would be min(2 sin, 2 cos)(theta/2).
    thetas = np.radians(np.arange(0, 171, 10))
    gt = np.array([[axis_quat([0, 0, 1], a)] for a in thetas])
    pred = np.array([[axis_quat([0, 0, 1], -a)] for a in thetas])
    gt_c, pred_c = lm.quat_continuous(gt), lm.quat_continuous(pred, first=gt[0])
    expected = np.mean(2 * np.sin(thetas / 2))
    aligned = np.mean(np.minimum(2 * np.sin(thetas / 2), 2 * np.cos(thetas / 2)))
    assert lm.l2q(gt_c[None], pred_c[None]) == pytest.approx(expected, rel=1e-12)
    assert lm.l2q(gt_c[None], lm.align_to(pred_c, gt_c)[None]) == pytest.approx(aligned, rel=1e-12)
    assert expected - aligned > 0.1


def test_global_quats_and_matrices_agree():
    parents = [-1, 0, 1, 1]
    local = random_quats((3, 4), seed=10)
    glob = lm.global_quats(local, parents)
    for t in range(3):
        world = []
        for j, p in enumerate(parents):
            m = quat_to_matrix(local[t, j])
            world.append(m if p < 0 else world[p] @ m)
            assert quat_to_matrix(glob[t, j]) == pytest.approx(world[j], abs=1e-12)
        back = lm.quat_from_matrix(lm.local_from_world(np.array(world), parents))
        assert np.abs(np.sum(back * local[t], -1)) == pytest.approx(np.ones(4), abs=1e-12)


# ----------------------------------------------------------------- L2P ----
def test_l2p_equals_a_loop_and_the_mean_cancels():
    gen = rng(11)
    gt, pred = gen.normal(size=(2, 4, 3, 3)), gen.normal(size=(2, 4, 3, 3))
    std, mean = gen.uniform(0.5, 2.0, size=9), gen.normal(size=9)
    assert lm.l2p(gt, pred, std) == pytest.approx(slow_l2p(gt, pred, mean, std), rel=1e-12)


def test_train_stats_equals_a_loop():
    gen = rng(12)
    clips = [(gen.normal(size=(n, 3, 3)), gen.normal(size=(n, 3))) for n in (4, 5, 11, 9)]
    mean, std, windows = lm.train_stats(clips, root=1, window=4, offset=2, n_past=2)
    smean, sstd, swindows = slow_train_stats(clips, 1, 4, 2, 2)
    # 4 frames: no window (start + 4 < 4 fails); 5: one; 11: starts 0, 2, 4, 6; 9: 0, 2, 4
    assert windows == swindows == 0 + 1 + 4 + 3
    assert mean == pytest.approx(smean, abs=1e-12)
    assert std == pytest.approx(sstd, rel=1e-12)


def test_window_frame_faces_plus_x():
    assert lm.facing_yaw(np.array([0.0, 0.3, 2.0])) == pytest.approx(math.pi / 2)
    turned = lm.to_window_frame(np.array([[1.0, 5.0, 3.0]]), (1.0, 1.0), math.pi / 2)
    assert turned[0] == pytest.approx([2.0, 5.0, 0.0], abs=1e-12)
    assert lm.facing_yaw(np.array([0.0, 1.0, 0.0])) == 0.0  # vertical: no turn


def chain_motion(frames, seed):
    """A 3-joint chain (root, child, grandchild) moving over `frames`: world
    positions (T, 3, 3) and rotations (T, 3, 3, 3), and its parents."""
    gen = rng(seed)
    parents = [-1, 0, 1]
    offsets = [None, np.array([0.0, 0.5, 0.0]), np.array([0.3, 0.0, 0.1])]
    pos, rot = np.zeros((frames, 3, 3)), np.zeros((frames, 3, 3, 3))
    base = gen.normal(size=(3, 3))
    speed = gen.normal(scale=0.1, size=(3, 3))
    for t in range(frames):
        for j, p in enumerate(parents):
            m = np.eye(3)
            for axis in range(3):
                q = np.zeros(3)
                q[axis] = 1.0
                m = m @ quat_to_matrix(axis_quat(q, base[j, axis] + speed[j, axis] * t))
            if p < 0:
                pos[t, j], rot[t, j] = [0.1 * t, 0.9, 0.05 * t], m
            else:
                pos[t, j], rot[t, j] = pos[t, p] + rot[t, p] @ offsets[j], rot[t, p] @ m
    return pos, rot, parents


def moved(pos, rot, angle, shift):
    """The same motion turned by `angle` about +Y and shifted on the ground."""
    y = lm.yaw_matrix(angle)
    return pos @ y.T + np.array([shift[0], 0.0, shift[1]]), np.einsum("ij,tnjk->tnik", y, rot)


def test_window_measures_do_not_depend_on_where_the_motion_is():
    gt_pos, gt_rot, parents = chain_motion(8, seed=13)
    pred_pos, pred_rot, _ = chain_motion(8, seed=14)
    pred_pos[0], pred_rot[0] = gt_pos[0], gt_rot[0]  # the context frame is shared
    std = np.array([0.5, 0.1, 0.2] * 3)
    a = lm.window_measures(gt_pos, gt_rot, pred_pos, pred_rot, parents, 0, [0, 1, 2], std)
    g2 = moved(gt_pos, gt_rot, 1.1, (4.0, -7.0))
    p2 = moved(pred_pos, pred_rot, 1.1, (4.0, -7.0))
    b = lm.window_measures(*g2, *p2, parents, 0, [0, 1, 2], std)
    for k in a:
        assert b[k] == pytest.approx(a[k], rel=1e-9, abs=1e-12)
    # normalised in the world frame instead (no centring, no turn), the same
    # motion turned scores differently: the spread differs between axes
    world = lm.l2p(gt_pos[None, 1:-1], pred_pos[None, 1:-1], std)
    world_turned = lm.l2p(g2[0][None, 1:-1], p2[0][None, 1:-1], std)
    assert abs(world - world_turned) > 1e-3


def test_window_measures_turn_the_root_to_face_plus_x():
    # The root, turned by 0.7 rad about +Y, faces (sin .7, 0, cos .7) (its
    # local forward axis is +z). The window's frame turns that onto +X: by
    # pi/2 - .7 about +Y. An error of .3 along the world's +z becomes
    # .3 (sin(pi/2 - .7), 0, cos(pi/2 - .7)) there, each axis divided by its
    # own std.
    parents = [-1]
    t_n = 3
    yaw = 0.7
    rot = np.tile(lm.yaw_matrix(yaw), (t_n, 1, 1, 1))
    gt_pos = np.zeros((t_n, 1, 3))
    pred_pos = gt_pos.copy()
    pred_pos[1, 0] = [0.0, 0.0, 0.3]  # 0.3 along world +z at the one fill frame
    std = np.array([1.0, 1.0, 2.0])
    m = lm.window_measures(gt_pos, rot, pred_pos, rot, parents, 0, [0], std)
    ang = math.pi / 2 - yaw
    err = np.array([0.3 * math.sin(ang), 0.0, 0.3 * math.cos(ang)])
    assert m["l2p"] == pytest.approx(math.hypot(err[0] / 1.0, err[2] / 2.0), rel=1e-12)
    assert m["l2q"] == pytest.approx(0.0, abs=1e-12)


def test_window_measures_charge_a_turn_the_other_way():
    # Joint 1 spins about +Y by +10 degrees a frame in the ground truth and
    # -10 in the prediction, over 0..350 degrees: the rotations agree again
    # near 180 and 360 degrees (where aligned signs cost little), but their
    # continuous quaternions do not: each frame costs 2 |sin(theta / 2)|.
    t_n = 36
    thetas = np.radians(10.0 * np.arange(t_n))
    parents = [-1, 0]
    gt_rot = np.array([[np.eye(3), lm.yaw_matrix(a)] for a in thetas])
    pred_rot = np.array([[np.eye(3), lm.yaw_matrix(-a)] for a in thetas])
    pos = np.zeros((t_n, 2, 3))
    m = lm.window_measures(pos, gt_rot, pos, pred_rot, parents, 0, [0, 1], np.ones(6))
    fill = thetas[1:-1]
    assert m["l2q"] == pytest.approx(np.mean(2 * np.abs(np.sin(fill / 2))), rel=1e-9)
    aligned = np.mean(np.minimum(2 * np.abs(np.sin(fill / 2)), 2 * np.abs(np.cos(fill / 2))))
    assert m["l2q"] - aligned > 0.3


# ---------------------------------------------------- the script's FK ----
BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Head
    {
      OFFSET 0 20 5
      CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 5 0
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.0333333
1 90 2 10 20 30 5 -15 40 0 21 6 -70 3 12
2 91 3 12 25 -150 6 -10 45 1 22 5 -60 4 10
3 92 4 14 30 170 7 -5 50 0 20 4 -50 5 8
"""


def test_script_forward_kinematics_equals_the_per_frame_form(tmp_path):
    loader = SourceFileLoader("inbetween_benchmark", os.path.join(SCRIPTS, "inbetween-benchmark"))
    bench = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name, loader))
    loader.exec_module(bench)
    path = tmp_path / "chain.bvh"
    path.write_text(BVH)
    b = bench.Bvh(str(path))
    pos, rot = b.world()
    for f in range(3):
        p, r = bench.world_from_locals(b, *b.local(f))
        assert pos[f] == pytest.approx(p, abs=1e-12)
        assert rot[f] == pytest.approx(r, abs=1e-12)
    assert b.values.shape == (3, 15)
    hips, joints = bench.scored_joints(b)
    assert (hips, joints) == (0, [0, 1, 2])


def test_method_query_sets_context_and_transition_time_on_a_copy():
    loader = SourceFileLoader("inbetween_benchmark", os.path.join(SCRIPTS, "inbetween-benchmark"))
    bench = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name, loader))
    loader.exec_module(bench)
    query = {"frames": [{"bvh": "t.bvh", "frame": 40, "time_s": 0},
                        {"bvh": "t.bvh", "frame": 71, "time_s": 1.0}]}
    assert bench.method_query(query, ["--no-warp"]) is query
    q = bench.method_query(query, ["context=10", "context_weight=2", "transition_time=0.1"])
    assert q["frames"][0]["context"] == {"before": 10, "weight": 2.0}
    assert "context" not in q["frames"][1]
    assert q["transition_time"] == 0.1
    assert "context" not in query["frames"][0] and "transition_time" not in query
    assert "context" not in bench.method_query(query, ["context=0"])["frames"][0]


def test_strict_keys_read_past_frames_and_a_lone_target(tmp_path):
    loader = SourceFileLoader("inbetween_benchmark", os.path.join(SCRIPTS, "inbetween-benchmark"))
    bench = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name, loader))
    loader.exec_module(bench)
    take = tmp_path / "take.bvh"
    rows = [f"{f} 0 0 0 0 {f * 2}" for f in range(40)]
    take.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition "
                    "Zposition Zrotation Xrotation Yrotation\n  End Site\n  {\n    OFFSET 0 1 0\n"
                    "  }\n}\nMOTION\nFrames: 40\nFrame Time: 0.0333333\n" + "\n".join(rows) + "\n")
    query = {"id": "q", "frames": [{"bvh": str(take), "frame": 25, "time_s": 0},
                                   {"bvh": str(take), "frame": 31, "time_s": 0.2}]}
    q = bench.strict_query(query, str(take), 25, 31, str(tmp_path))
    assert query["frames"][0]["bvh"] == str(take)  # the original is left alone
    k1, k2 = q["frames"][0], q["frames"][1]
    assert (k1["frame"], k2["frame"]) == (10, 0)
    assert (k1["time_s"], k2["time_s"]) == (0, 0.2)
    first = open(k1["bvh"]).read().split("Frame Time: 0.0333333\n")
    assert first[0].endswith("MOTION\nFrames: 11\n")
    assert first[1].split("\n")[:-1] == rows[15:26]
    second = open(k2["bvh"]).read()
    assert "Frames: 1\n" in second and second.endswith(rows[31] + "\n")
    # Near the start of the take the first excerpt has what there is.
    q = bench.strict_query(query, str(take), 4, 10, str(tmp_path))
    assert q["frames"][0]["frame"] == 4
    assert "Frames: 5\n" in open(q["frames"][0]["bvh"]).read()
