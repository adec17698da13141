"""naic_core's dynamics against two independent implementations.

naic side: `cargo run --release -p naic_core --example dump_dynamics -- URDF STATES.json`
(Model::from_urdf_file + Data<Dyn>; the 6-DOF stack path is checked equal to it
bit for bit in crates/naic_core/tests/dynamics.rs).

* Pinocchio 4.1 loading the same urdf/jk5.urdf: RNEA, bias and gravity torques,
  M (CRBA), ABA, `tip` and `ft_sensor` poses, LOCAL_WORLD_ALIGNED Jacobians and
  classical accelerations (J̇q̇) at 250 random states. Same algorithms in the same
  floating-point arithmetic, so we ask 1e-9 relative (measured: ~1e-15).
* MuJoCo 4.0 on the authors' MJCF (jk5_table.nomesh.mjcf.xml; site `ee` = tip,
  body `ee_link` = ft_sensor), contacts and constraints disabled: qfrc_bias, M,
  qacc, mj_inverse, site/body poses, mj_jacSite/mj_jacBody, mj_jacDot. A
  different model file (the URDF is a conversion of it) and different
  algorithms (CRB + LDL); we ask 1e-6 relative (measured: ~1e-13).
* Pinocchio on the test URDFs of the Rust tests (general axes, prismatic,
  continuous, merged fixed links, a planar arm): the same 1e-9.

Relative error = max |naic − ref| / max |ref| over one state's quantity.
"""
import json
import math
import os
import pathlib
import subprocess

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")
mujoco = pytest.importorskip("mujoco")

N_STATES = 250
SEED = 20261122
TOL_PIN = 1e-9
TOL_MJ = 1e-6
FRAMES = ["tip", "ft_sensor"]


@pytest.fixture(scope="module")
def dump_bin(root):
    subprocess.run(["cargo", "build", "--release", "-q", "--workspace", "--example", "dump_dynamics"],
                   cwd=root, check=True)
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", root / "target"))
    return target / "release" / "examples" / "dump_dynamics"


def joint_ranges(model):
    """Per-DOF position range for naic's q (one angle per joint; ±π for continuous)."""
    lo, hi = [], []
    for j in model.joints[1:]:
        if j.nq == 2:  # Pinocchio's continuous joint: q = (cos θ, sin θ)
            lo.append(-math.pi), hi.append(math.pi)
        else:
            lo.append(max(model.lowerPositionLimit[j.idx_q], -math.pi))
            hi.append(min(model.upperPositionLimit[j.idx_q], math.pi))
    return np.array(lo), np.array(hi)


def pin_q(model, q):
    """naic's q (one angle per joint) as Pinocchio's configuration vector."""
    out = np.zeros(model.nq)
    for k, j in enumerate(model.joints[1:]):
        if j.nq == 2:
            out[j.idx_q:j.idx_q + 2] = math.cos(q[k]), math.sin(q[k])
        else:
            out[j.idx_q] = q[k]
    return out


def random_states(model, n, seed):
    """q in the joint range (±π where unbounded), v in ±π, a in ±10, tau in ±50."""
    rng = np.random.default_rng(seed)
    lo, hi = joint_ranges(model)
    out = []
    for _ in range(n):
        out.append(dict(q=rng.uniform(lo, hi).tolist(), v=rng.uniform(-math.pi, math.pi, model.nv).tolist(),
                        a=rng.uniform(-10, 10, model.nv).tolist(), tau=rng.uniform(-50, 50, model.nv).tolist()))
    return out


def run_dump(dump_bin, urdf, frames, states, tmp_path):
    path = tmp_path / "states.json"
    path.write_text(json.dumps(dict(frames=frames, states=states)))
    r = subprocess.run([str(dump_bin), str(urdf), str(path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def rel_err(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


class Worst:
    """Largest error per quantity; asserts each against a tolerance."""

    def __init__(self, tol):
        self.tol, self.worst = tol, {}

    def __call__(self, key, got, ref, i):
        e = rel_err(got, ref)
        self.worst[key] = max(self.worst.get(key, 0.0), e)
        assert e <= self.tol, f"{key}: relative error {e:.3e} > {self.tol:.0e} at state {i}"

    def report(self, title):
        print(f"\n{title}: worst relative error per quantity")
        for k, v in sorted(self.worst.items()):
            print(f"  {k:24s} {v:.2e}")


def compare_with_pinocchio(model, out, states, frames):
    data = model.createData()
    check = Worst(TOL_PIN)
    assert out["nv"] == model.nv
    assert out["joint_names"] == list(model.names)[1:]
    for i, (s, r) in enumerate(zip(states, out["results"])):
        q, v, a, tau = (np.array(s[k]) for k in ("q", "v", "a", "tau"))
        q = pin_q(model, q)
        check("rnea", r["rnea"], pin.rnea(model, data, q, v, a), i)
        check("bias", r["bias"], pin.rnea(model, data, q, v, np.zeros(model.nv)), i)
        check("gravity", r["gravity"], pin.computeGeneralizedGravity(model, data, q), i)
        m = pin.crba(model, data, q)
        m = np.triu(m) + np.triu(m, 1).T
        check("M", r["M"], m, i)
        check("aba", r["aba"], pin.aba(model, data, q, v, tau), i)
        pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
        pin.updateFramePlacements(model, data)
        pin.computeJointJacobians(model, data, q)
        for f in frames:
            fid = model.getFrameId(f)
            got = r["frames"][f]
            check(f"{f}.position", got["pos"], data.oMf[fid].translation, i)
            check(f"{f}.rotation", got["rot"], data.oMf[fid].rotation, i)
            check(f"{f}.J", got["J"], pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED), i)
            acc = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            check(f"{f}.jdot_qdot", got["jdot_qdot"], np.concatenate([acc.linear, acc.angular]), i)
    return check


def test_jk5_matches_pinocchio(root, dump_bin, tmp_path):
    urdf = root / "urdf" / "jk5.urdf"
    model = pin.buildModelFromUrdf(str(urdf))
    states = random_states(model, N_STATES, SEED)
    out = run_dump(dump_bin, urdf, FRAMES, states, tmp_path)
    assert len(out["results"]) == N_STATES
    compare_with_pinocchio(model, out, states, FRAMES).report("naic vs Pinocchio, urdf/jk5.urdf")


def example_robot_data_urdf(*parts):
    """A URDF of the pip package `example-robot-data` (tests/requirements.txt), read where
    the package installs it (its cmeel prefix's share folder), never copied."""
    import sysconfig
    for key in ("purelib", "platlib"):
        base = pathlib.Path(sysconfig.get_paths()[key]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if base.is_dir():
            path = base.joinpath(*parts)
            assert path.is_file(), f"example-robot-data has no {path}"
            return path
    pytest.skip("example-robot-data is not installed (pip install -r tests/requirements.txt)")


# Issue 37's arms: the Panda of urdf/, UR5 and UR10 of example-robot-data. Each: RNEA, bias,
# gravity, CRBA, ABA, frame poses, Jacobians and J̇q̇ at random states, 1e-9 relative.
ARMS = {
    "panda": (lambda root: root / "urdf" / "panda.urdf", ["flange", "link7"], 7),
    "ur5": (lambda root: example_robot_data_urdf("ur_description", "urdf", "ur5_robot.urdf"), ["tool0", "ee_link"], 6),
    "ur10": (lambda root: example_robot_data_urdf("ur_description", "urdf", "ur10_robot.urdf"), ["tool0", "ee_link"], 6),
}


@pytest.mark.parametrize("arm", sorted(ARMS))
def test_arms_match_pinocchio(root, dump_bin, tmp_path, arm):
    where, frames, nv = ARMS[arm]
    urdf = where(root)
    model = pin.buildModelFromUrdf(str(urdf))
    assert model.nv == nv, f"{arm}: Pinocchio reads {model.nv} joints"
    states = random_states(model, 100, SEED + 4)
    out = run_dump(dump_bin, urdf, frames, states, tmp_path)
    assert len(out["results"]) == len(states)
    compare_with_pinocchio(model, out, states, frames).report(f"naic vs Pinocchio, {arm} ({urdf.name})")


@pytest.mark.parametrize("name,frames", [("arm6", ["tip", "camera", "s4"]), ("planar3", ["tip", "l2"])])
def test_test_urdfs_match_pinocchio(dump_bin, tmp_path, name, frames):
    """General axes, prismatic and continuous joints, merged fixed links."""
    xml = subprocess.run([str(dump_bin), "--test-urdf", name], capture_output=True, text=True, check=True).stdout
    urdf = tmp_path / f"{name}.urdf"
    urdf.write_text(xml)
    model = pin.buildModelFromUrdf(str(urdf))
    states = random_states(model, 100, SEED + 1)
    out = run_dump(dump_bin, urdf, frames, states, tmp_path)
    compare_with_pinocchio(model, out, states, frames).report(f"naic vs Pinocchio, {name}")


def test_jk5_matches_mujoco(root, shared, dump_bin, tmp_path):
    m = mujoco.MjModel.from_xml_path(str(shared / "reference" / "jk5" / "jk5_table.nomesh.mjcf.xml"))
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    assert m.nq == m.nv == 6
    for field in ("dof_armature", "dof_damping", "dof_frictionloss", "jnt_stiffness"):
        assert np.all(getattr(m, field) == 0), field
    d = mujoco.MjData(m)
    site_ee = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "ee")
    body_ee = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "ee_link")
    assert site_ee >= 0 and body_ee >= 0
    urdf = root / "urdf" / "jk5.urdf"
    model = pin.buildModelFromUrdf(str(urdf))  # only for the joint ranges
    states = random_states(model, N_STATES, SEED + 2)
    out = run_dump(dump_bin, urdf, FRAMES, states, tmp_path)
    check = Worst(TOL_MJ)
    jp, jr = np.zeros((3, 6)), np.zeros((3, 6))
    M = np.zeros((6, 6))
    for i, (s, r) in enumerate(zip(states, out["results"])):
        q, v, a, tau = (np.array(s[k]) for k in ("q", "v", "a", "tau"))
        d.qpos[:], d.qvel[:], d.ctrl[:], d.qfrc_applied[:] = q, v, 0.0, tau
        mujoco.mj_forward(m, d)
        check("bias", r["bias"], d.qfrc_bias, i)
        mujoco.mj_fullM(m, d, M)
        check("M", r["M"], M, i)
        check("aba", r["aba"], d.qacc, i)
        points = {"tip": (d.site_xpos[site_ee], d.site_xmat[site_ee], m.site_bodyid[site_ee]),
                  "ft_sensor": (d.xpos[body_ee], d.xmat[body_ee], body_ee)}
        for f, (pos, mat, body) in points.items():
            got = r["frames"][f]
            check(f"{f}.position", got["pos"], pos, i)
            check(f"{f}.rotation", got["rot"], np.asarray(mat).reshape(3, 3), i)
            mujoco.mj_jac(m, d, jp, jr, pos, body)
            check(f"{f}.J", got["J"], np.vstack([jp, jr]), i)
            mujoco.mj_jacDot(m, d, jp, jr, pos, body)
            check(f"{f}.jdot_qdot", got["jdot_qdot"], np.concatenate([jp @ v, jr @ v]), i)
        d.qacc[:] = a
        mujoco.mj_inverse(m, d)
        check("rnea", r["rnea"], d.qfrc_inverse, i)
    check.report("naic vs MuJoCo, jk5_table.nomesh.mjcf.xml")


def test_cartesian_terms_match_eq3_from_pinocchio(root, dump_bin, tmp_path):
    """D = J⁻ᵀ M J⁻¹ and h = J⁻ᵀ(C q̇ + G) − D J̇ q̇ (eq. 3) at the tip, from
    Pinocchio's M, bias, J and J̇q̇, where J is well conditioned (naic's own
    undamped inverse is then exact)."""
    urdf = root / "urdf" / "jk5.urdf"
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    states = random_states(model, 100, SEED + 3)
    out = run_dump(dump_bin, urdf, ["tip"], states, tmp_path)
    fid = model.getFrameId("tip")
    checked = 0
    for i, (s, r) in enumerate(zip(states, out["results"])):
        q, v = np.array(s["q"]), np.array(s["v"])
        c = r["cartesian"]
        pin.forwardKinematics(model, data, q, v, np.zeros(6))
        pin.updateFramePlacements(model, data)
        J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        sigma = np.linalg.svd(J, compute_uv=False)
        assert c["sigma_min"] == pytest.approx(sigma.min(), rel=1e-9, abs=1e-12)
        assert c["damped"] == (sigma.min() < 0.02)
        if sigma.min() < 0.05:
            continue
        acc = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
        jdq = np.concatenate([acc.linear, acc.angular])
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        b = pin.rnea(model, data, q, v, np.zeros(6))
        Ji = np.linalg.inv(J)
        D = Ji.T @ M @ Ji
        h = Ji.T @ b - D @ jdq
        # J⁻¹ amplifies rounding by cond(J) (< 1e3 here), so 1e-9 · cond
        cond = sigma.max() / sigma.min()
        assert rel_err(c["D"], D) <= 1e-12 * cond * cond, f"D at state {i}"
        assert rel_err(c["h"], h) <= 1e-12 * cond * cond, f"h at state {i}"
        checked += 1
    assert checked >= 30


def test_bench_dynamics_cli(root, naic_bin, dump_bin, tmp_path):
    """`naic bench dynamics --json` prints one JSON line with every figure (no timing is asserted)."""
    r = subprocess.run([str(naic_bin), "bench", "dynamics", "--json", "--batches", "50"],
                       cwd=root, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 1
    out = json.loads(lines[0])
    for k in ("rnea_ns", "crba_ns", "aba_ns", "frame_jacobian_ns", "controller_step_ns"):
        assert isinstance(out[k], float) and out[k] > 0, k
    assert out["nv"] == 6 and out["path"] == "static6"
    # a non-6-joint chain runs the dynamic-size path and has no controller figure
    xml = subprocess.run([str(dump_bin), "--test-urdf", "planar3"],
                         capture_output=True, text=True)
    if xml.returncode == 0:
        planar = tmp_path / "planar3.urdf"
        planar.write_text(xml.stdout)
        r = subprocess.run([str(naic_bin), "bench", "dynamics", "--json", "--batches", "50", "--urdf", str(planar)],
                           cwd=root, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        out = json.loads(r.stdout)
        assert out["path"] == "dynamic" and out["controller_step_ns"] is None
    # bad input: clear message, exit 2, no panic
    for args, words in ((["--urdf", str(tmp_path / "missing.urdf")], ["missing.urdf", "not found"]),
                        (["--frame", "nowhere"], ["nowhere", "frames are"]),
                        (["--batches", "3"], ["at least 50"])):
        r = subprocess.run([str(naic_bin), "bench", "dynamics", "--json", *args],
                           cwd=root, capture_output=True, text=True, timeout=300)
        assert r.returncode == 2, (args, r.stderr)
        assert "panicked" not in r.stderr
        for w in words:
            assert w in r.stderr, (args, r.stderr)
