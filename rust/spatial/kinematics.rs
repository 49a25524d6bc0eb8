//! Frames, forward kinematics and cable geometry of spatial arms
//! (`docs/spatial.md`): the chain of joints and disks, the end pose as a
//! matrix and as `[x, y, z, rx, ry, rz]`, the geometric Jacobian, the world
//! hole points and every cable's length and Jacobian. nalgebra fixed-size
//! work throughout.

use crate::model::SpatialRobot;
use nalgebra::{Matrix3, Rotation3, Unit, UnitQuaternion, Vector3};

type V3 = Vector3<f64>;

/// A rigid frame: rotation `r` and origin `p` in the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub r: Matrix3<f64>,
    pub p: V3,
}

impl Frame {
    pub fn identity() -> Frame {
        Frame {
            r: Matrix3::identity(),
            p: V3::zeros(),
        }
    }

    /// The frame moved by `t` along its own axes.
    #[inline]
    pub fn translated(&self, t: &[f64; 3]) -> Frame {
        Frame {
            r: self.r,
            p: self.p + self.r * V3::new(t[0], t[1], t[2]),
        }
    }

    /// A point given in this frame, in the base frame.
    #[inline]
    pub fn point(&self, q: &[f64; 3]) -> V3 {
        self.p + self.r * V3::new(q[0], q[1], q[2])
    }

    /// Row-major 4x4 homogeneous matrix.
    pub fn matrix(&self) -> [f64; 16] {
        let mut m = [0.0; 16];
        for i in 0..3 {
            for j in 0..3 {
                m[4 * i + j] = self.r[(i, j)];
            }
            m[4 * i + 3] = self.p[i];
        }
        m[15] = 1.0;
        m
    }
}

/// The chain at one configuration: every joint's position `p` and world axis
/// `w`, and the faces of every disk (`face_a[k]`, `face_b[k]` for disk
/// `k + 1`; the base face is the identity).
#[derive(Debug, Clone, Default)]
pub struct Chain {
    pub p: Vec<V3>,
    pub w: Vec<V3>,
    pub face_a: Vec<Frame>,
    pub face_b: Vec<Frame>,
    /// Disk (1-based) of each joint.
    pub disk_of: Vec<usize>,
}

impl Chain {
    pub fn new(robot: &SpatialRobot) -> Chain {
        let n = robot.n();
        let k = robot.disks.len();
        let mut disk_of = vec![0; n];
        for (d, disk) in robot.disks.iter().enumerate() {
            for j in disk.joints.clone() {
                disk_of[j] = d + 1;
            }
        }
        Chain {
            p: vec![V3::zeros(); n],
            w: vec![V3::zeros(); n],
            face_a: vec![Frame::identity(); k],
            face_b: vec![Frame::identity(); k],
            disk_of,
        }
    }

    /// Fills the chain at `theta` (rad).
    pub fn at(&mut self, robot: &SpatialRobot, theta: &[f64]) {
        let mut f = Frame::identity();
        for (d, disk) in robot.disks.iter().enumerate() {
            for j in disk.joints.clone() {
                let joint = &robot.joints[j];
                f = f.translated(&joint.offset);
                let a = V3::new(joint.axis[0], joint.axis[1], joint.axis[2]);
                self.p[j] = f.p;
                self.w[j] = f.r * a;
                let rot = Rotation3::from_axis_angle(&Unit::new_unchecked(a), theta[j]);
                f.r *= rot.matrix();
            }
            let fa = f.translated(&disk.link_after);
            let fb = fa.translated(&[disk.thickness, 0.0, 0.0]);
            self.face_a[d] = fa;
            self.face_b[d] = fb;
            f = fb;
        }
    }

    /// The end frame (distal face of the last disk).
    pub fn end(&self) -> &Frame {
        self.face_b.last().expect("a robot has at least one disk")
    }

    /// `dq/dtheta_j` of a point `q` on disk `disk` (0 = base).
    #[inline]
    pub fn point_rate(&self, q: &V3, disk: usize, j: usize) -> V3 {
        if self.disk_of[j] <= disk {
            self.w[j].cross(&(q - self.p[j]))
        } else {
            V3::zeros()
        }
    }
}

/// `[x, y, z, rx, ry, rz]` of a frame: origin (m) and rotation vector (rad,
/// angle in `[0, pi]`).
pub fn pose_vector(f: &Frame) -> [f64; 6] {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(f.r));
    let r = q.scaled_axis();
    [f.p[0], f.p[1], f.p[2], r[0], r[1], r[2]]
}

/// The rotation matrix of a rotation vector (rad).
pub fn rotation_of(v: &[f64; 3]) -> Matrix3<f64> {
    *Rotation3::new(V3::new(v[0], v[1], v[2])).matrix()
}

/// The rotation vector (rad) of a rotation matrix.
pub fn log_of(r: &Matrix3<f64>) -> V3 {
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r)).scaled_axis()
}

/// The world hole points of cable `c`: `B_0, A_1, B_1, ..., A_e, B_e`.
pub fn cable_points(robot: &SpatialRobot, chain: &Chain, c: usize, out: &mut Vec<V3>) {
    let cable = &robot.cables[c];
    out.clear();
    let h = &cable.holes;
    out.push(V3::new(h[0][0], h[0][1], h[0][2]));
    for k in 1..=cable.end {
        out.push(chain.face_a[k - 1].point(&h[2 * k - 1]));
        out.push(chain.face_b[k - 1].point(&h[2 * k]));
    }
}

/// Length of cable `c` (m) and, when `jac` is given, its row `dL_c/dtheta` (`n`).
pub fn cable_length(
    robot: &SpatialRobot,
    chain: &Chain,
    c: usize,
    pts: &mut Vec<V3>,
    jac: Option<&mut [f64]>,
) -> f64 {
    cable_points(robot, chain, c, pts);
    let end = robot.cables[c].end;
    let mut len = 0.0;
    for k in 1..=end {
        len += (pts[2 * k - 1] - pts[2 * k - 2]).norm() + (pts[2 * k] - pts[2 * k - 1]).norm();
    }
    if let Some(row) = jac {
        row.fill(0.0);
        for k in 1..=end {
            let (a, b) = (pts[2 * k - 1], pts[2 * k - 2]);
            let s = a - b;
            let l = s.norm();
            if l == 0.0 {
                continue;
            }
            let u = s / l;
            for (j, v) in row.iter_mut().enumerate() {
                let rate = chain.point_rate(&a, k, j) - chain.point_rate(&b, k - 1, j);
                *v += u.dot(&rate);
            }
        }
    }
    len
}

/// Geometric Jacobian `(6, n)` row-major of the end frame: linear velocity of
/// its origin, then angular velocity.
pub fn geometric_jacobian(chain: &Chain, out: &mut [f64]) {
    let n = chain.p.len();
    let tip = chain.end().p;
    for j in 0..n {
        let v = chain.w[j].cross(&(tip - chain.p[j]));
        for i in 0..3 {
            out[i * n + j] = v[i];
            out[(3 + i) * n + j] = chain.w[j][i];
        }
    }
}
