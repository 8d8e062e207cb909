//! Rigid transforms evaluated at generation time (fixed joint origins and their products).

pub type Mat3 = [[f64; 3]; 3];
pub type Vec3 = [f64; 3];

/// `rot` is row-major: `rot[i][j]` is row `i`, column `j`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub rot: Mat3,
    pub pos: Vec3,
}

impl Transform {
    pub const IDENTITY: Transform = Transform {
        rot: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        pos: [0.0; 3],
    };

    /// A URDF `<origin xyz rpy>`: rotation `Rz(yaw) * Ry(pitch) * Rx(roll)`, then translation.
    pub fn from_xyz_rpy(xyz: Vec3, rpy: Vec3) -> Transform {
        let (sr, cr) = rpy[0].sin_cos();
        let (sp, cp) = rpy[1].sin_cos();
        let (sy, cy) = rpy[2].sin_cos();
        let rot = [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ];
        Transform { rot, pos: xyz }
    }

    /// `self * other`.
    pub fn compose(&self, other: &Transform) -> Transform {
        let mut rot = [[0.0; 3]; 3];
        for (i, row) in rot.iter_mut().enumerate() {
            for (j, r) in row.iter_mut().enumerate() {
                *r = (0..3).map(|k| self.rot[i][k] * other.rot[k][j]).sum();
            }
        }
        Transform {
            rot,
            pos: add(self.rotate(other.pos), self.pos),
        }
    }

    pub fn rotate(&self, v: Vec3) -> Vec3 {
        self.rot.map(|row| dot(row, v))
    }
}

pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn norm(v: Vec3) -> f64 {
    dot(v, v).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpy_matches_successive_axis_rotations() {
        let (r, p, y) = (0.3, -0.7, 1.1);
        let rx = Transform::from_xyz_rpy([0.0; 3], [r, 0.0, 0.0]);
        let ry = Transform::from_xyz_rpy([0.0; 3], [0.0, p, 0.0]);
        let rz = Transform::from_xyz_rpy([0.0; 3], [0.0, 0.0, y]);
        let expected = rz.compose(&ry).compose(&rx);
        let t = Transform::from_xyz_rpy([0.0; 3], [r, p, y]);
        for i in 0..3 {
            for j in 0..3 {
                assert!((t.rot[i][j] - expected.rot[i][j]).abs() < 1e-15);
            }
        }
        // Rx alone, spelled out: a positive roll turns y towards z.
        assert!((rx.rot[2][1] - r.sin()).abs() < 1e-15);
    }
}
