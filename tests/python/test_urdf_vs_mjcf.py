"""urdf/jk5.urdf against the authors' MuJoCo model it was converted from.

Two independent implementations: Pinocchio (loads our URDF) and MuJoCo (loads
shared/reference/jk5/jk5_table.nomesh.mjcf.xml). If the URDF is the exact
conversion, both must give the same mass matrix, bias torques, forward dynamics,
frame poses and Jacobians up to floating-point rounding.

Tolerances. The conversion only re-expresses each number (quat -> rpy,
diag inertia + quat -> full tensor), so the two models differ by a few ulp per
parameter; what remains is rounding in two different recursive algorithms. Measured
over 2000 random states: <= 3e-15 relative on M, bias torques, positions, rotations
and Jacobians. We assert 1e-12 (400x margin for other CPUs/BLAS; still a million
times tighter than any real modelling error, e.g. a 0.1 mm offset or 1 g mass gives
>= 1e-5). Forward dynamics (ABA vs MuJoCo's LDL solve) amplifies rounding by the
condition number of M (up to ~2e4 here); measured error / cond(M) <= 1.5e-17, so
we assert |dqdd|/|qdd| <= 1e-14 * cond(M) (<= 2e-10 in the worst state).
"""
import math
import pathlib
import subprocess
import sys

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")
mujoco = pytest.importorskip("mujoco")

N_STATES = 250
SEED = 20260522
TOL = 1e-12
ABA_TOL_PER_COND = 1e-14
JOINTS = [f"joint{i}" for i in range(1, 7)]


@pytest.fixture(scope="module")
def urdf_path(root):
    return root / "urdf" / "jk5.urdf"


@pytest.fixture(scope="module")
def mjcf(shared):
    return shared / "reference" / "jk5" / "jk5_table.mjcf.xml"


@pytest.fixture(scope="module")
def mjcf_nomesh(shared):
    return shared / "reference" / "jk5" / "jk5_table.nomesh.mjcf.xml"


@pytest.fixture(scope="module")
def pin_model(urdf_path):
    model = pin.buildModelFromUrdf(str(urdf_path))
    return model


@pytest.fixture(scope="module")
def mj_model(mjcf_nomesh):
    m = mujoco.MjModel.from_xml_path(str(mjcf_nomesh))
    # Rigid-body dynamics only: no contacts (the table), no joint-limit constraints.
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return m


def converter(root, *args):
    return subprocess.run([sys.executable, str(root / "tools" / "mjcf_to_urdf.py"), *map(str, args)],
                          capture_output=True, cwd=root)


def rel_err(a, b):
    """max |a - b| relative to the largest entry of the reference b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


# ---------------------------------------------------------------- the file itself

def test_regenerating_gives_committed_file_byte_for_byte(root, mjcf, urdf_path):
    out = converter(root, mjcf, "-o", "-")
    assert out.returncode == 0, out.stderr.decode()
    assert out.stdout == urdf_path.read_bytes(), (
        "urdf/jk5.urdf is not what tools/mjcf_to_urdf.py makes from the MJCF; regenerate it")
    check = converter(root, mjcf, "--check", "-o", urdf_path)
    assert check.returncode == 0, check.stderr.decode()


def test_nomesh_variant_converts_to_the_same_model(root, mjcf, mjcf_nomesh):
    """The dynamics checks load the .nomesh. MJCF: it must be the same robot."""
    full = converter(root, mjcf, "-o", "-").stdout.decode()
    nomesh = converter(root, mjcf_nomesh, "-o", "-").stdout.decode()
    body = lambda s: s[s.index("<robot"):]
    assert body(full) == body(nomesh)


def test_converter_rejects_bad_input_with_clear_message(root, mjcf, tmp_path):
    missing = converter(root, tmp_path / "nope.xml", "-o", "-")
    assert missing.returncode == 2
    assert b"cannot read the MJCF" in missing.stderr and b"Traceback" not in missing.stderr
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body name='jk5'>")
    r = converter(root, bad, "-o", "-")
    assert r.returncode == 2 and b"not valid XML" in r.stderr and b"Traceback" not in r.stderr
    noroot = tmp_path / "noroot.xml"
    noroot.write_text("<mujoco><worldbody><body name='arm'/></worldbody></mujoco>")
    r = converter(root, noroot, "-o", "-")
    assert r.returncode == 2 and b"no top-level body named 'jk5'" in r.stderr
    euler = tmp_path / "euler.xml"
    euler.write_text("<mujoco><worldbody><body name='jk5'><body name='l1' euler='0 0 1'>"
                     "<joint name='j'/></body></body></worldbody></mujoco>")
    r = converter(root, euler, "-o", "-")
    assert r.returncode == 2 and b"euler" in r.stderr
    stale = tmp_path / "stale.urdf"
    stale.write_text("<robot/>")
    r = converter(root, mjcf, "--check", "-o", stale)
    assert r.returncode == 1 and b"regenerate" in r.stderr


# ---------------------------------------------------------------- structure

def test_structure_names_axes_limits(pin_model):
    model = pin_model
    assert model.nq == 6 and model.nv == 6
    assert list(model.names)[1:] == JOINTS
    for name in ("base_link", "ft_sensor", "tip"):
        assert model.existFrame(name), name
    for j in range(1, 7):
        assert model.joints[j].shortname() == "JointModelRZ"  # revolute about local z
    np.testing.assert_array_equal(model.lowerPositionLimit, [-3.14] * 6)
    np.testing.assert_array_equal(model.upperPositionLimit, [3.14] * 6)
    np.testing.assert_array_equal(model.effortLimit, [100.0] * 6)
    np.testing.assert_array_equal(model.velocityLimit, [math.pi] * 6)
    # tip: 0.169 m along ft_sensor z, same orientation; ft_sensor on joint6.
    tip = model.frames[model.getFrameId("tip")]
    fts = model.frames[model.getFrameId("ft_sensor")]
    assert tip.parentJoint == fts.parentJoint == 6
    rel = fts.placement.inverse() * tip.placement
    np.testing.assert_allclose(rel.translation, [0, 0, 0.169], atol=1e-15)
    np.testing.assert_allclose(rel.rotation, np.eye(3), atol=1e-15)


def test_mujoco_model_has_nothing_urdf_cannot_express(mj_model):
    m = mj_model
    assert m.nq == m.nv == 6
    for field in ("dof_armature", "dof_damping", "dof_frictionloss", "jnt_stiffness"):
        assert np.all(getattr(m, field) == 0), field
    np.testing.assert_array_equal(m.opt.gravity, [0, 0, -9.81])  # = Pinocchio's default
    assert np.all(m.actuator_gear[:, 0] == 1)


def test_q0_pose_matches_provenance(pin_model):
    """PROVENANCE.md: at q = 0 the arm points straight up, tip at (0, -0.3765, 1.0635)."""
    data = pin_model.createData()
    pin.framesForwardKinematics(pin_model, data, np.zeros(6))
    np.testing.assert_allclose(data.oMf[pin_model.getFrameId("tip")].translation,
                               [0, -0.3765, 1.0635], atol=1e-12)
    # tool axis (ft_sensor z) points along world -y at q = 0
    np.testing.assert_allclose(data.oMf[pin_model.getFrameId("ft_sensor")].rotation[:, 2],
                               [0, -1, 0], atol=1e-12)


def test_total_moving_mass_is_jk5_not_zu5(pin_model, mj_model):
    """Links 1-6 + sensor/rod: 4.27+10.1+2.61+1.45+1.45+0.21+0.424 = 20.514 kg,
    not the 92.35 kg moving mass of JAKA's Zu 5 URDF (PROVENANCE.md)."""
    moving = sum(pin_model.inertias[j].mass for j in range(1, pin_model.njoints))
    assert moving == pytest.approx(20.514, abs=1e-12)
    assert abs(moving - 92.35) > 50
    mj_moving = sum(mj_model.body_mass[b] for b in range(mj_model.nbody)
                    if mj_model.body_weldid[b] != 0)  # bodies not welded to the world
    assert moving == pytest.approx(mj_moving, rel=1e-15)


# ---------------------------------------------------------------- dynamics and kinematics

def test_dynamics_and_kinematics_match_mujoco(pin_model, mj_model):
    model, m = pin_model, mj_model
    data, d = model.createData(), mujoco.MjData(m)
    tip, fts = model.getFrameId("tip"), model.getFrameId("ft_sensor")
    site_ee = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "ee")
    body_tip = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "tip")
    body_ee = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "ee_link")
    assert min(site_ee, body_tip, body_ee) >= 0
    qpos_adr = [m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)] for j in JOINTS]
    assert qpos_adr == list(range(6))

    rng = np.random.default_rng(SEED)
    worst = {}

    def check(key, got, ref, tol=TOL):
        e = rel_err(got, ref)
        worst[key] = max(worst.get(key, 0.0), e)
        assert e <= tol, f"{key}: relative error {e:.3e} > {tol:.1e} at state {i}"

    jp, jr = np.zeros((3, 6)), np.zeros((3, 6))
    M_mj = np.zeros((6, 6))
    for i in range(N_STATES):
        q = rng.uniform(-3.14, 3.14, 6)       # the joint range
        v = rng.uniform(-math.pi, math.pi, 6)  # the velocity limit
        tau = rng.uniform(-100, 100, 6)        # the effort limit
        d.qpos[:], d.qvel[:], d.ctrl[:], d.qfrc_applied[:] = q, v, 0.0, tau
        mujoco.mj_forward(m, d)

        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T  # Pinocchio fills the upper triangle
        mujoco.mj_fullM(m, d, M_mj)
        check("mass matrix", M, M_mj)
        check("bias torques", pin.nonLinearEffects(model, data, q, v), d.qfrc_bias)
        qdd = pin.aba(model, data, q, v, tau)
        check("aba", qdd, d.qacc, tol=ABA_TOL_PER_COND * np.linalg.cond(M_mj))

        pin.framesForwardKinematics(model, data, q)
        check("tip position", data.oMf[tip].translation, d.site_xpos[site_ee])
        check("tip position (body)", data.oMf[tip].translation, d.xpos[body_tip])
        check("tip rotation", data.oMf[tip].rotation, d.xmat[body_tip].reshape(3, 3))
        check("ft_sensor position", data.oMf[fts].translation, d.xpos[body_ee])
        check("ft_sensor rotation", data.oMf[fts].rotation, d.xmat[body_ee].reshape(3, 3))

        mujoco.mj_jacSite(m, d, jp, jr, site_ee)
        J = pin.computeFrameJacobian(model, data, q, tip, pin.LOCAL_WORLD_ALIGNED)
        check("tip jacobian", J, np.vstack([jp, jr]))
        mujoco.mj_jacBody(m, d, jp, jr, body_ee)
        J = pin.computeFrameJacobian(model, data, q, fts, pin.LOCAL_WORLD_ALIGNED)
        check("ft_sensor jacobian", J, np.vstack([jp, jr]))

    print("worst relative errors over", N_STATES, "states:",
          {k: f"{v:.2e}" for k, v in worst.items()})
