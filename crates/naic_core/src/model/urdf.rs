//! URDF → [`Model`]: validation, fixed-link merging, frames.

use super::{AxisKind, Frame, FrameKind, JointLimits, JointModel, JointType, Model, ModelError};
use crate::dynamics::spatial::{Inertia, Se3};
use nalgebra::{Matrix3, Rotation3, SymmetricEigen, Vector3};
use std::collections::HashMap;
use std::path::Path;

pub(super) fn from_file(path: &Path) -> Result<Model, ModelError> {
    if !path.exists() {
        return Err(ModelError::FileNotFound { path: path.to_path_buf() });
    }
    let text = std::fs::read_to_string(path)
        .map_err(|e| ModelError::Io { path: path.to_path_buf(), reason: e.to_string() })?;
    from_str(&text, &format!(" {}", path.display()))
}

const KNOWN_TYPES: [&str; 7] =
    ["revolute", "continuous", "prismatic", "fixed", "floating", "planar", "spherical"];

/// When urdf-rs refuses the text, look for a joint with an unknown type so
/// the error can name it (serde's message does not).
fn find_unknown_joint_type(xml: &str) -> Option<(String, String)> {
    let mut rest = xml;
    while let Some(i) = rest.find("<joint") {
        rest = &rest[i + 6..];
        let end = rest.find('>')?;
        let tag = &rest[..end];
        let attr = |key: &str| -> Option<String> {
            let mut s = tag;
            loop {
                let k = s.find(key)?;
                let before = s[..k].chars().last();
                s = &s[k + key.len()..];
                if before.is_some_and(|c| !c.is_whitespace()) {
                    continue;
                }
                let t = s.trim_start();
                let t = t.strip_prefix('=')?.trim_start();
                // The quote character (any character in a damaged file: slice past its
                // UTF-8 length, not one byte).
                let q = t.chars().next()?;
                let t = &t[q.len_utf8()..];
                return Some(t[..t.find(q)?].to_string());
            }
        };
        if let Some(kind) = attr("type") {
            if !KNOWN_TYPES.contains(&kind.as_str()) {
                return Some((attr("name").unwrap_or_else(|| "?".into()), kind));
            }
        }
    }
    None
}

fn finite(what: impl FnOnce() -> String, v: f64) -> Result<f64, ModelError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ModelError::NonFinite { what: what(), value: v })
    }
}

fn pose(p: &urdf_rs::Pose, what: &str) -> Result<Se3, ModelError> {
    for (k, v) in p.xyz.0.iter().enumerate() {
        finite(|| format!("{what} <origin xyz> component {k}"), *v)?;
    }
    for (k, v) in p.rpy.0.iter().enumerate() {
        finite(|| format!("{what} <origin rpy> component {k}"), *v)?;
    }
    let r = Rotation3::from_euler_angles(p.rpy.0[0], p.rpy.0[1], p.rpy.0[2]);
    Ok(Se3::new(*r.matrix(), Vector3::from(p.xyz.0)))
}

fn link_inertia(link: &urdf_rs::Link) -> Result<Inertia, ModelError> {
    let name = &link.name;
    let i = &link.inertial;
    let mass = finite(|| format!("link '{name}' <mass value>"), i.mass.value)?;
    let t = &i.inertia;
    for (k, v) in [("ixx", t.ixx), ("ixy", t.ixy), ("ixz", t.ixz), ("iyy", t.iyy), ("iyz", t.iyz), ("izz", t.izz)] {
        finite(|| format!("link '{name}' <inertia {k}>"), v)?;
    }
    if mass < 0.0 {
        return Err(ModelError::NegativeMass { link: name.clone(), mass });
    }
    let tensor = Matrix3::new(t.ixx, t.ixy, t.ixz, t.ixy, t.iyy, t.iyz, t.ixz, t.iyz, t.izz);
    if mass == 0.0 {
        if tensor.iter().any(|v| *v != 0.0) {
            return Err(ModelError::MassZeroWithInertia { link: name.clone() });
        }
        return Ok(Inertia::zero());
    }
    let eig = SymmetricEigen::new(tensor).eigenvalues;
    let mut m = [eig[0], eig[1], eig[2]];
    m.sort_by(|a, b| a.total_cmp(b));
    let scale = m[2].abs().max(f64::MIN_POSITIVE);
    // Point masses (all moments 0) are allowed; negative moments are not.
    if m[0] < -1e-12 * scale {
        return Err(ModelError::InertiaNotPositive { link: name.clone(), moments: m });
    }
    if m[0] + m[1] < m[2] * (1.0 - 1e-9) - 1e-12 * scale {
        return Err(ModelError::InertiaTriangle { link: name.clone(), moments: m });
    }
    let frame = pose(&i.origin, &format!("link '{name}' <inertial>"))?;
    Ok(frame.act_inertia(&Inertia { mass, com: Vector3::zeros(), inertia: tensor }))
}

pub(super) fn from_str(xml: &str, origin: &str) -> Result<Model, ModelError> {
    build(&parse(xml, origin)?)
}

fn parse(xml: &str, origin: &str) -> Result<urdf_rs::Robot, ModelError> {
    match urdf_rs::read_from_string(xml) {
        Ok(r) => Ok(r),
        Err(e) => {
            if let Some((joint, kind)) = find_unknown_joint_type(xml) {
                return Err(ModelError::UnknownJointType { joint, kind });
            }
            Err(ModelError::Parse { origin: origin.to_string(), reason: e.to_string() })
        }
    }
}

/// The actuated chain from the root to `tip_link`: every moving joint that is not an
/// ancestor of `tip_link` is locked at 0 (turned into a fixed joint, so its links' mass
/// stays on the body they hang from, as Pinocchio's `buildReducedModel` does). Returns the
/// model and the names of the locked joints. Without such joints the model is exactly
/// [`from_str`]'s.
pub(super) fn from_str_chain(xml: &str, origin: &str, tip_link: &str) -> Result<(Model, Vec<String>), ModelError> {
    let mut robot = parse(xml, origin)?;
    if !robot.links.iter().any(|l| l.name == tip_link) {
        return Err(ModelError::UnknownLink { link: tip_link.to_string() });
    }
    // Walk from the tip link up to the root through the parent joints.
    let mut on_path: Vec<&str> = Vec::new();
    let mut link = tip_link.to_string();
    for _ in 0..=robot.joints.len() {
        let Some(j) = robot.joints.iter().find(|j| j.child.link == link) else { break };
        on_path.push(j.name.as_str());
        link = j.parent.link.clone();
    }
    let on_path: Vec<String> = on_path.into_iter().map(String::from).collect();
    let mut locked = Vec::new();
    for j in &mut robot.joints {
        use urdf_rs::JointType as T;
        let moving = matches!(j.joint_type, T::Revolute | T::Continuous | T::Prismatic);
        if moving && !on_path.contains(&j.name) {
            j.joint_type = T::Fixed;
            locked.push(j.name.clone());
        }
    }
    Ok((build(&robot)?, locked))
}

/// Where a link sits: on which joint's body (None = base) and at which pose in it.
#[derive(Clone)]
struct LinkPlace {
    body: Option<usize>,
    placement: Se3,
}

fn build(robot: &urdf_rs::Robot) -> Result<Model, ModelError> {
    // Names.
    let mut link_index: HashMap<&str, usize> = HashMap::new();
    for (i, l) in robot.links.iter().enumerate() {
        if link_index.insert(l.name.as_str(), i).is_some() {
            return Err(ModelError::DuplicateName { what: "link", name: l.name.clone() });
        }
    }
    let mut seen = HashMap::new();
    for j in &robot.joints {
        if seen.insert(j.name.as_str(), ()).is_some() {
            return Err(ModelError::DuplicateName { what: "joint", name: j.name.clone() });
        }
    }
    // Tree structure.
    let mut parent_joint: Vec<Option<usize>> = vec![None; robot.links.len()];
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); robot.links.len()];
    for (ji, j) in robot.joints.iter().enumerate() {
        use urdf_rs::JointType as T;
        match j.joint_type {
            T::Revolute | T::Continuous | T::Prismatic | T::Fixed => {}
            T::Floating | T::Planar | T::Spherical => {
                let kind = format!("{:?}", j.joint_type).to_lowercase();
                return Err(ModelError::UnsupportedJointType { joint: j.name.clone(), kind });
            }
        }
        let p = *link_index.get(j.parent.link.as_str()).ok_or_else(|| ModelError::MissingLink {
            joint: j.name.clone(),
            role: "parent",
            link: j.parent.link.clone(),
        })?;
        let c = *link_index.get(j.child.link.as_str()).ok_or_else(|| ModelError::MissingLink {
            joint: j.name.clone(),
            role: "child",
            link: j.child.link.clone(),
        })?;
        if let Some(prev) = parent_joint[c] {
            return Err(ModelError::MultipleParents {
                link: j.child.link.clone(),
                first: robot.joints[prev].name.clone(),
                second: j.name.clone(),
            });
        }
        parent_joint[c] = Some(ji);
        children[p].push(ji);
    }
    let roots: Vec<usize> = (0..robot.links.len()).filter(|&l| parent_joint[l].is_none()).collect();
    match roots.len() {
        0 => return Err(ModelError::NoRoot),
        1 => {}
        _ => {
            return Err(ModelError::MultipleRoots {
                links: roots.iter().map(|&l| robot.links[l].name.clone()).collect(),
            })
        }
    }

    // Depth-first traversal from the root: frames, bodies, merged inertias.
    let mut joints: Vec<JointModel> = Vec::new();
    let mut frames: Vec<Frame> = Vec::new();
    // The moving joint already hanging from each body (index 0 = base, i+1 = joint i).
    let mut moving_child: HashMap<Option<usize>, String> = HashMap::new();
    let mut body_inertia: Vec<Inertia> = Vec::new();
    let mut place: Vec<Option<LinkPlace>> = vec![None; robot.links.len()];
    let root = roots[0];
    place[root] = Some(LinkPlace { body: None, placement: Se3::identity() });
    frames.push(Frame {
        name: robot.links[root].name.clone(),
        kind: FrameKind::Link,
        parent: None,
        placement: Se3::identity(),
    });
    // The root link is part of the fixed base: validate its inertial but ignore it.
    link_inertia(&robot.links[root])?;
    let mut stack: Vec<usize> = children[root].iter().rev().copied().collect();
    while let Some(ji) = stack.pop() {
        let j = &robot.joints[ji];
        let p = link_index[j.parent.link.as_str()];
        let c = link_index[j.child.link.as_str()];
        // Depth-first from the root: the parent link is always placed already.
        let Some(parent_place) = place[p].clone() else { return Err(ModelError::NoRoot) };
        let origin = pose(&j.origin, &format!("joint '{}'", j.name))?;
        let inertia = link_inertia(&robot.links[c])?;
        let child_place = if j.joint_type == urdf_rs::JointType::Fixed {
            let placement = parent_place.placement.compose(&origin);
            frames.push(Frame {
                name: j.name.clone(),
                kind: FrameKind::FixedJoint,
                parent: parent_place.body,
                placement,
            });
            if let Some(b) = parent_place.body {
                body_inertia[b] = body_inertia[b].add(&placement.act_inertia(&inertia));
            }
            LinkPlace { body: parent_place.body, placement }
        } else {
            if let Some(first) = moving_child.insert(parent_place.body, j.name.clone()) {
                let link = match parent_place.body {
                    None => robot.links[root].name.clone(),
                    Some(b) => joints[b].child_link.clone(),
                };
                return Err(ModelError::Branching { link, first, second: j.name.clone() });
            }
            let mut axis = Vector3::from(j.axis.xyz.0);
            for k in 0..3 {
                finite(|| format!("joint '{}' <axis xyz> component {k}", j.name), axis[k])?;
            }
            let norm = axis.norm();
            if norm < 1e-12 {
                return Err(ModelError::ZeroAxis { joint: j.name.clone() });
            }
            axis /= norm;
            let axis_kind = if axis == Vector3::x() {
                AxisKind::X
            } else if axis == Vector3::y() {
                AxisKind::Y
            } else if axis == Vector3::z() {
                AxisKind::Z
            } else {
                AxisKind::General
            };
            let l = &j.limit;
            for (k, v) in [("lower", l.lower), ("upper", l.upper), ("velocity", l.velocity), ("effort", l.effort)] {
                if v.is_nan() {
                    return Err(ModelError::NonFinite { what: format!("joint '{}' <limit {k}>", j.name), value: v });
                }
            }
            let jtype = match j.joint_type {
                urdf_rs::JointType::Prismatic => JointType::Prismatic,
                urdf_rs::JointType::Continuous => JointType::Continuous,
                _ => JointType::Revolute,
            };
            let limits = if jtype == JointType::Continuous {
                JointLimits { lower: f64::NEG_INFINITY, upper: f64::INFINITY, velocity: l.velocity, effort: l.effort }
            } else {
                if l.lower > l.upper {
                    return Err(ModelError::BadLimits { joint: j.name.clone(), lower: l.lower, upper: l.upper });
                }
                JointLimits { lower: l.lower, upper: l.upper, velocity: l.velocity, effort: l.effort }
            };
            // The parent body of a chain is the previous joint; the new joint's
            // placement is relative to the previous joint frame (or the base).
            let placement = parent_place.placement.compose(&origin);
            let idx = joints.len();
            debug_assert_eq!(parent_place.body, idx.checked_sub(1));
            joints.push(JointModel {
                name: j.name.clone(),
                jtype,
                axis,
                axis_kind,
                placement,
                inertia: Inertia::zero(),
                limits,
                child_link: j.child.link.clone(),
            });
            body_inertia.push(inertia);
            frames.push(Frame { name: j.name.clone(), kind: FrameKind::Joint, parent: Some(idx), placement: Se3::identity() });
            LinkPlace { body: Some(idx), placement: Se3::identity() }
        };
        frames.push(Frame {
            name: robot.links[c].name.clone(),
            kind: FrameKind::Link,
            parent: child_place.body,
            placement: child_place.placement,
        });
        place[c] = Some(child_place);
        stack.extend(children[c].iter().rev().copied());
    }
    let unreached: Vec<String> =
        (0..robot.links.len()).filter(|&l| place[l].is_none()).map(|l| robot.links[l].name.clone()).collect();
    if !unreached.is_empty() {
        return Err(ModelError::Loop { links: unreached });
    }
    if joints.is_empty() {
        return Err(ModelError::NoMovingJoints);
    }
    for (j, y) in joints.iter_mut().zip(body_inertia) {
        j.inertia = y;
    }
    // Every joint must move some inertia (else M is singular): check the
    // composite inertia of its subtree about its axis at q = 0.
    let mut composite = Inertia::zero();
    for i in (0..joints.len()).rev() {
        composite = joints[i].inertia.add(&composite);
        let s = joints[i].s_mul(1.0);
        let moved = s.dot_force(&composite.mul_motion(&s));
        let scale = 1.0 + composite.mass;
        if !(moved > 1e-12 * scale) {
            return Err(ModelError::SingularJoint { joint: joints[i].name.clone() });
        }
        if i > 0 {
            composite = joints[i].placement.act_inertia(&composite);
        }
    }
    Ok(Model { name: robot.name.clone(), joints, frames, gravity: Vector3::new(0.0, 0.0, -9.81) })
}
