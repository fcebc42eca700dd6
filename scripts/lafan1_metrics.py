"""In-betweening measures as LaFAN1's benchmark code defines them.

The definitions are those of the reference code that comes with LaFAN1
(Harvey et al., "Robust Motion In-betweening", SIGGRAPH 2020; Ubisoft La
Forge, repository ubisoft/ubisoft-laforge-animation-dataset, files
lafan1/benchmarks.py, lafan1/utils.py and lafan1/extract.py). This module is
written from those definitions; it shares no code with them.

    L2P   mean over the transition's frames of the L2 norm, over all joints'
          coordinates, of the difference of the global joint positions, each
          coordinate first normalised by the mean and standard deviation of
          the training windows. Positions are in a window's own frame:
          centred on the root's ground position and turned about the
          vertical so that the root faces +X at the last context frame.
    L2Q   mean over the transition's frames of the L2 norm, over all joints'
          quaternion components, of the difference of the global
          quaternions; quaternions are made continuous over time (a sign
          flip where the dot product with the previous frame's is
          negative), never aligned with the ground truth's.
    NPSS  for every (sequence, feature) of the global quaternions, the
          power spectrum over the transition's frames is the square of the
          FFT's real part, normalised to sum 1; the earth mover's distance
          between the two spectra's cumulative sums; the average of these
          distances over all sequences and features weighted by the ground
          truth's total power.

Arrays are numpy arrays of floats. Quaternions are (w, x, y, z), Hamilton
products; the vertical axis is +Y (as in LaFAN1 and Bandai Namco's files).
Every function raises ValueError on shapes that do not match, on empty
arrays and on values that are not finite.
"""
import math

import numpy as np

TRAIN_WINDOW = 50  # extract.get_train_stats: windows of 50 frames ...
TRAIN_OFFSET = 20  # ... every 20 frames
N_PAST = 10  # context frames before a transition; the last one orients a window


def _array(x, name, ndim=None, last=None):
    a = np.asarray(x, dtype=float)
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name}: expected {ndim} dimensions, got shape {a.shape}")
    if last is not None and (a.ndim == 0 or a.shape[-1] != last):
        raise ValueError(f"{name}: expected a last dimension of {last}, got shape {a.shape}")
    if a.size == 0:
        raise ValueError(f"{name}: empty array (shape {a.shape})")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: values that are not finite")
    return a


def _same_shape(a, b, names):
    if a.shape != b.shape:
        raise ValueError(f"{names}: shapes differ, {a.shape} and {b.shape}")


# ------------------------------------------------------------ quaternions ----
def quat_from_matrix(m):
    """Rotation matrices (..., 3, 3) -> unit quaternions (..., 4), w first.

    The sign of each quaternion is whichever the largest of |w|, |x|, |y|, |z|
    makes positive; callers that need a sign convention impose one
    (quat_continuous). The matrices are assumed to be rotations (not checked
    beyond their shape)."""
    m = _array(m, "matrices")
    if m.ndim < 2 or m.shape[-2:] != (3, 3):
        raise ValueError(f"matrices: expected (..., 3, 3), got shape {m.shape}")
    r = m.reshape(-1, 3, 3)
    t = np.trace(r, axis1=1, axis2=2)
    # 4 w^2, 4 x^2, 4 y^2, 4 z^2 from the diagonal; the largest is divided by.
    d = np.stack([1 + t, 1 + 2 * r[:, 0, 0] - t, 1 + 2 * r[:, 1, 1] - t, 1 + 2 * r[:, 2, 2] - t], 1)
    k = np.argmax(d, axis=1)
    s = 2 * np.sqrt(np.maximum(d[np.arange(len(r)), k], 1e-300))  # = 4 |largest component|
    q = np.empty((len(r), 4))
    w = k == 0
    q[w] = np.stack([s[w] / 4, (r[w, 2, 1] - r[w, 1, 2]) / s[w], (r[w, 0, 2] - r[w, 2, 0]) / s[w],
                     (r[w, 1, 0] - r[w, 0, 1]) / s[w]], 1)
    x = k == 1
    q[x] = np.stack([(r[x, 2, 1] - r[x, 1, 2]) / s[x], s[x] / 4, (r[x, 0, 1] + r[x, 1, 0]) / s[x],
                     (r[x, 0, 2] + r[x, 2, 0]) / s[x]], 1)
    y = k == 2
    q[y] = np.stack([(r[y, 0, 2] - r[y, 2, 0]) / s[y], (r[y, 0, 1] + r[y, 1, 0]) / s[y], s[y] / 4,
                     (r[y, 1, 2] + r[y, 2, 1]) / s[y]], 1)
    z = k == 3
    q[z] = np.stack([(r[z, 1, 0] - r[z, 0, 1]) / s[z], (r[z, 0, 2] + r[z, 2, 0]) / s[z],
                     (r[z, 1, 2] + r[z, 2, 1]) / s[z], s[z] / 4], 1)
    return q.reshape(m.shape[:-2] + (4,))


def quat_mul(a, b):
    """Hamilton product a b of quaternions (..., 4) (broadcast): the rotation
    b first, then a."""
    a, b = _array(a, "a", last=4), _array(b, "b", last=4)
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], -1)


def quat_continuous(q, first=None):
    """Quaternions (T, ..., 4) over T frames with their signs made continuous:
    frame t is negated where its dot product with frame t-1 (as already
    processed) is negative, as utils.remove_quat_discontinuities does (a dot
    product of exactly 0 keeps the sign). With `first` (..., 4), frame 0 is
    first negated where its dot product with `first` is negative: a window
    whose first frame is a context frame takes the ground truth's sign there.
    Returns a new array; T = 1 is allowed (nothing to make continuous)."""
    q = _array(q, "quaternions", last=4).copy()
    if q.ndim < 2:
        raise ValueError(f"quaternions: expected (T, ..., 4), got shape {q.shape}")
    if first is not None:
        first = _array(first, "first", last=4)
        _same_shape(q[0], first, "quaternions[0], first")
        q[0] = np.where(np.sum(q[0] * first, -1, keepdims=True) < 0, -q[0], q[0])
    for t in range(1, len(q)):
        q[t] = np.where(np.sum(q[t] * q[t - 1], -1, keepdims=True) < 0, -q[t], q[t])
    return q


def global_quats(local, parents):
    """Forward kinematics of local quaternions (T, J, 4) over a hierarchy
    (parents[j] < j, -1 for a root): global quaternions (T, J, 4), each the
    product of its parent's global and its own local (utils.quat_fk). The
    signs follow from the local ones: continuous local quaternions give
    continuous global ones."""
    local = _array(local, "local quaternions", ndim=3, last=4)
    if len(parents) != local.shape[1]:
        raise ValueError(f"parents: {len(parents)} joints, quaternions have {local.shape[1]}")
    out = np.empty_like(local)
    for j, p in enumerate(parents):
        if p >= j:
            raise ValueError(f"parents: joint {j}'s parent {p} does not come before it")
        out[:, j] = local[:, j] if p < 0 else quat_mul(out[:, p], local[:, j])
    return out


def local_from_world(rot, parents):
    """Local rotation matrices (..., J, 3, 3) from world ones: a joint's
    parent's world rotation transposed times its own (a root's is its world)."""
    rot = _array(rot, "rotations")
    if rot.ndim < 3 or rot.shape[-2:] != (3, 3) or rot.shape[-3] != len(parents):
        raise ValueError(f"rotations: expected (..., {len(parents)}, 3, 3), got {rot.shape}")
    out = rot.copy()
    for j, p in enumerate(parents):
        if p >= 0:
            out[..., j, :, :] = np.swapaxes(rot[..., p, :, :], -1, -2) @ rot[..., j, :, :]
    return out


# ----------------------------------------------------------------- facing ----
def facing_yaw(forward):
    """The angle (radians) of the turn about +Y that takes the ground
    projection (x, z) of `forward` (3,) onto +X (utils.rotate_at_frame turns
    the root's forward direction at the last context frame onto +X). A
    forward direction with no ground component (vertical) gives 0: no turn
    (the reference would divide by its length, about 0)."""
    f = _array(forward, "forward", ndim=1, last=3)
    if math.hypot(f[0], f[2]) < 1e-12:
        return 0.0
    return math.atan2(f[2], f[0])


def yaw_matrix(angle):
    """Rotation matrix (3, 3) by `angle` radians about +Y."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def yaw_quat(angle):
    """Quaternion (4,) of the rotation by `angle` radians about +Y."""
    return np.array([math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])


def to_window_frame(pos, centre_xz, angle):
    """Positions (..., 3) moved into a window's frame: minus the centre's
    ground position (x, z) (height kept), then turned by `angle` about +Y."""
    pos = _array(pos, "positions", last=3)
    c = np.array([centre_xz[0], 0.0, centre_xz[1]])
    return (pos - c) @ yaw_matrix(angle).T


# ------------------------------------------------------------------ stats ----
def train_stats(clips, root, window=TRAIN_WINDOW, offset=TRAIN_OFFSET, n_past=N_PAST):
    """Mean and standard deviation of every joint coordinate over the
    training windows, as extract.get_train_stats computes them.

    clips: iterable of (positions (T, J, 3), forward (T, 3)): every joint's
        global position (any unit; the result is in the same) and the root's
        forward direction in the world, frame by frame;
    root: the index of the root joint among the J.
    Windows of `window` frames start at frames 0, offset, 2 offset, ... while
    start + window < T (strictly, as the reference's loop); each is centred
    on its root's mean ground position (x, z) over the window and turned
    about +Y so that the root faces +X at its frame n_past - 1. The mean and
    the (population) standard deviation are over all frames of all windows
    (overlapping windows count a frame more than once).
    Returns (mean (J * 3,), std (J * 3,), number of windows). Raises
    ValueError when no clip is long enough for a window, or when the joints
    differ between clips."""
    if window < 1 or offset < 1 or not 1 <= n_past <= window:
        raise ValueError(f"window {window}, offset {offset}, n_past {n_past}: not a valid window")
    count, mean, m2, windows, dims = 0, None, None, 0, None
    for pos, forward in clips:
        pos = _array(pos, "positions", ndim=3, last=3)
        forward = _array(forward, "forward", ndim=2, last=3)
        if len(forward) != len(pos):
            raise ValueError(f"forward: {len(forward)} frames, positions {len(pos)}")
        if dims is None:
            dims = pos.shape[1] * 3
        elif pos.shape[1] * 3 != dims:
            raise ValueError(f"positions: {pos.shape[1]} joints, the first clip had {dims // 3}")
        xs = []
        i = 0
        while i + window < len(pos):
            w = pos[i:i + window]
            centre = w[:, root, [0, 2]].mean(axis=0)
            angle = facing_yaw(forward[i + n_past - 1])
            xs.append(to_window_frame(w, centre, angle).reshape(window, -1))
            i += offset
        if not xs:
            continue
        x = np.concatenate(xs)
        windows += len(xs)
        # Chan et al.'s combination of two sets' counts, means and squared deviations
        n, mu, s2 = len(x), x.mean(axis=0), ((x - x.mean(axis=0)) ** 2).sum(axis=0)
        if mean is None:
            count, mean, m2 = n, mu, s2
        else:
            d = mu - mean
            total = count + n
            mean = mean + d * n / total
            m2 = m2 + s2 + d * d * count * n / total
            count = total
    if mean is None:
        raise ValueError(f"no training window: every clip has at most {window} frames")
    return mean, np.sqrt(m2 / count), windows


# --------------------------------------------------------------- measures ----
def l2p(gt, pred, std):
    """LaFAN1's L2P: the mean over sequences and frames of the L2 norm, over
    all joints' coordinates, of (pred - gt) / std.

    gt, pred: (B, T, J, 3) global positions in the windows' frame (the unit
        of std); std: (J * 3,), the training windows' standard deviation,
        joint-major (x, y, z of joint 0, then joint 1, ...), all > 0.
    The reference normalises both by (x - mean) / std; the mean cancels in
    the difference. Result: unitless (standard deviations)."""
    gt = _array(gt, "gt", ndim=4, last=3)
    pred = _array(pred, "pred", ndim=4, last=3)
    _same_shape(gt, pred, "gt, pred")
    std = _array(std, "std", ndim=1)
    if std.shape[0] != gt.shape[2] * 3:
        raise ValueError(f"std: {std.shape[0]} values, expected {gt.shape[2] * 3} (joints x 3)")
    if np.any(std <= 0):
        raise ValueError("std: a coordinate with no spread (standard deviation <= 0)")
    d = (pred - gt).reshape(gt.shape[0], gt.shape[1], -1) / std
    return float(np.sqrt((d * d).sum(axis=-1)).mean())


def l2q(gt, pred):
    """LaFAN1's L2Q: the mean over sequences and frames of the L2 norm, over
    all joints' components, of pred - gt.

    gt, pred: (B, T, J, 4) global quaternions, each sequence already made
    continuous in time (quat_continuous; the reference reads its files so),
    with no alignment of pred's signs to gt's: a prediction whose sign path
    differs from the ground truth's is charged for it (up to 2 per joint).
    Result: unitless; 0 for identical sequences."""
    gt = _array(gt, "gt", ndim=4, last=4)
    pred = _array(pred, "pred", ndim=4, last=4)
    _same_shape(gt, pred, "gt, pred")
    d = (pred - gt).reshape(gt.shape[0], gt.shape[1], -1)
    return float(np.sqrt((d * d).sum(axis=-1)).mean())


def npss_terms(gt, pred):
    """Per sequence and feature, the two parts of LaFAN1's NPSS
    (benchmarks.fast_npss): the earth mover's distance between the
    normalised power spectra, and the ground truth's total power (its
    weight).

    gt, pred: (B, T, D) sequences over time (axis 1). Power: the square of
    the real part of the FFT over time (not its magnitude), at every one of
    the T frequencies; normalised to sum 1 over them; the distance is the
    L1 norm of the difference of the cumulative sums.
    Returns (emd (B, D), power (B, D)). A feature whose ground truth has no
    power (real part of its FFT all zero) gets weight 0 and distance 0 (the
    reference divides by zero there and its average is NaN); a predicted
    feature with no power where the ground truth has some raises ValueError
    (its spectrum cannot be normalised)."""
    gt = _array(gt, "gt", ndim=3)
    pred = _array(pred, "pred", ndim=3)
    _same_shape(gt, pred, "gt, pred")
    gp = np.real(np.fft.fft(gt, axis=1)) ** 2
    pp = np.real(np.fft.fft(pred, axis=1)) ** 2
    gtot, ptot = gp.sum(axis=1), pp.sum(axis=1)
    has = gtot > 0
    if np.any(has & ~(ptot > 0)):
        raise ValueError("pred: a feature with no power (the real part of its FFT is 0) "
                         "where the ground truth has some: NPSS is undefined")
    gcdf = np.cumsum(gp / np.where(has, gtot, 1)[:, None, :], axis=1)
    pcdf = np.cumsum(pp / np.where(ptot > 0, ptot, 1)[:, None, :], axis=1)
    emd = np.where(has, np.abs(pcdf - gcdf).sum(axis=1), 0.0)
    return emd, np.where(has, gtot, 0.0)


def npss(gt, pred):
    """LaFAN1's NPSS of (B, T, D) sequences: the average of npss_terms'
    distances over all B sequences and D features, weighted by the ground
    truth's total power (one figure for the whole batch, not a mean of
    per-sequence figures). Unitless, >= 0; 0 for identical spectra. Raises
    ValueError when no feature of the ground truth has power."""
    emd, power = npss_terms(gt, pred)
    if power.sum() <= 0:
        raise ValueError("gt: no feature has power; NPSS is undefined")
    return float((emd * power).sum() / power.sum())


def npss_magnitude(gt, pred):
    """This project's former NPSS of one (T, D) sequence: like npss but with
    the FFT's squared magnitude as the power (so a spectrum of a real signal
    is symmetric), features of no power left out of the normalisation, and
    the weights normalised within the sequence (a mean of per-fill figures is
    then taken, not one weighted figure over all fills). Kept for the tables
    that predate the reference-exact one; unitless."""
    gt = _array(gt, "gt", ndim=2)
    pred = _array(pred, "pred", ndim=2)
    _same_shape(gt, pred, "gt, pred")
    g = np.abs(np.fft.fft(gt, axis=0)) ** 2
    p = np.abs(np.fft.fft(pred, axis=0)) ** 2
    gs, ps = g.sum(axis=0), p.sum(axis=0)
    gn = g / np.where(gs > 0, gs, 1)
    pn = p / np.where(ps > 0, ps, 1)
    emd = np.abs(np.cumsum(gn, axis=0) - np.cumsum(pn, axis=0)).sum(axis=0)
    w = gs / gs.sum() if gs.sum() > 0 else np.full_like(gs, 1 / len(gs))
    return float((emd * w).sum())


def align_to(q, ref):
    """This project's former sign handling for L2Q: every quaternion (..., 4)
    negated where its dot product with the ground truth's `ref` is negative
    (so the error is the smaller of |q - ref| and |q + ref|)."""
    q, ref = _array(q, "q", last=4), _array(ref, "ref", last=4)
    _same_shape(q, ref, "q, ref")
    return np.where(np.sum(q * ref, -1, keepdims=True) < 0, -q, q)


# ----------------------------------------------------------------- window ----
def window_measures(gt_pos, gt_rot, pred_pos, pred_rot, parents, root, joints, std,
                    forward_axis=(0.0, 0.0, 1.0)):
    """LaFAN1's measures of one window of T = G + 2 frames: frame 0 the last
    context frame (the first key pose), frames 1..G the transition, frame
    G + 1 the target (the second key pose); only frames 1..G are scored.

    gt_pos, pred_pos: (T, N, 3) world positions of all N joints of the
        hierarchy `parents` (any unit, that of std);
    gt_rot, pred_rot: (T, N, 3, 3) world rotation matrices;
    root: the joint whose ground position and facing set the window's frame
        (the ground truth's at frame 0; its forward direction is its
        rotation applied to `forward_axis`, the rig's local forward axis);
    joints: the indices of the joints scored (J of them), in the order of
        std's (J * 3,) values.
    Positions go into the window's frame: centred on the root's ground
    position at frame 0 and turned so that its forward direction there is
    +X (the reference centres on the root's mean over its window: a
    translation, which cancels in L2P). Quaternions: local ones from the
    rotation matrices, made continuous over the window (the prediction's
    frame 0, the context frame, takes the ground truth's signs there, as the
    reference's predictions start from its context), global ones by forward
    kinematics, turned by the same yaw.
    Returns {"l2p": float, "l2q": float, "npss_emd_power": float,
    "npss_power": float}: the last two sum over the window's features, so
    that NPSS over many windows is sum(npss_emd_power) / sum(npss_power)."""
    gt_pos = _array(gt_pos, "gt positions", ndim=3, last=3)
    pred_pos = _array(pred_pos, "pred positions", ndim=3, last=3)
    _same_shape(gt_pos, pred_pos, "gt positions, pred positions")
    gt_rot = _array(gt_rot, "gt rotations", ndim=4)
    pred_rot = _array(pred_rot, "pred rotations", ndim=4)
    _same_shape(gt_rot, pred_rot, "gt rotations, pred rotations")
    if gt_rot.shape[:2] != gt_pos.shape[:2] or gt_rot.shape[2:] != (3, 3):
        raise ValueError(f"rotations {gt_rot.shape} do not match positions {gt_pos.shape}")
    if len(gt_pos) < 3:
        raise ValueError(f"a window of {len(gt_pos)} frames has no transition frame")
    joints = list(joints)
    if not joints:
        raise ValueError("joints: none scored")
    angle = facing_yaw(gt_rot[0, root] @ np.asarray(forward_axis, dtype=float))
    centre = gt_pos[0, root, [0, 2]]
    fill = slice(1, len(gt_pos) - 1)
    gp = to_window_frame(gt_pos[fill][:, joints], centre, angle)
    pp = to_window_frame(pred_pos[fill][:, joints], centre, angle)
    turn = yaw_quat(angle)
    gl = quat_continuous(quat_from_matrix(local_from_world(gt_rot, parents)))
    pl = quat_continuous(quat_from_matrix(local_from_world(pred_rot, parents)), first=gl[0])
    gq = quat_mul(turn, global_quats(gl, parents)[fill][:, joints])
    pq = quat_mul(turn, global_quats(pl, parents)[fill][:, joints])
    emd, power = npss_terms(gq.reshape(1, len(gq), -1), pq.reshape(1, len(pq), -1))
    return {"l2p": l2p(gp[None], pp[None], std), "l2q": l2q(gq[None], pq[None]),
            "npss_emd_power": float((emd * power).sum()), "npss_power": float(power.sum())}
