//! The calibration file's TOML writer: commented, in the layout of `docs/formats.md`, floats in
//! their shortest exact form.

use std::fmt::Write as _;
use std::path::Path;

use super::schema::Calibration;
use fringe3d_core::params::CameraParams;

impl Calibration {
    /// The TOML text [`Calibration::save`] writes.
    pub(super) fn to_toml(&self) -> Result<String, String> {
        let mut s = String::new();
        s.push_str(
            "# fringe3d calibration file, format version 1 (docs/formats.md).\n\
             # Frame: the camera's (OpenCV): origin at its centre of projection, x right, y down, z forward.\n\
             # Units: millimetres for positions and depths; pixels for fx, fy, cx, cy and sizes;\n\
             # skew (alpha of eq 4) and distortion [k1, k2, p1, p2, k3] are dimensionless.\n\
             # Pixel centres are at integer coordinates: (0, 0) is the centre of the top-left pixel.\n",
        );
        let _ = writeln!(s, "version = {}", self.version);
        let _ = writeln!(
            s,
            "projector_centre = {}  # P, mm",
            arr(&self.projector_centre)
        );
        let _ = writeln!(
            s,
            "depth_range = {}  # [z_min, z_max], mm",
            arr(&self.depth_range)
        );
        if let Some(d) = self.projector_defocus {
            let _ = writeln!(
                s,
                "projector_defocus = {}  # effective blur sigma, projector pixels (binary patterns)",
                num(d)
            );
        }
        s.push('\n');
        camera_toml(&mut s, "camera", &self.camera);
        if let Some(r) = &self.reference {
            s.push_str("\n[reference]\n");
            let _ = writeln!(s, "point = {}  # O_R, mm", arr(&r.point));
            let _ = writeln!(s, "normal = {}  # n_R, unit", arr(&r.normal));
            let _ = writeln!(
                s,
                "phase_map = {}  # float32 TIFF, relative to this file",
                toml_str(&r.phase_map)?
            );
            if let Some(p) = &r.pattern_set {
                let _ = writeln!(s, "pattern_set = {}", toml_str(p)?);
            }
            if let Some(m) = r.margin.filter(|m| m.iter().any(|&x| x > 0)) {
                let _ = writeln!(
                    s,
                    "margin = [{}, {}, {}, {}]  # the map past the image: left, top, right, bottom, pixels",
                    m[0], m[1], m[2], m[3]
                );
            }
            if let Some(d) = &r.pattern_digest {
                let _ = writeln!(
                    s,
                    "pattern_digest = {}  # the reference's pattern set (docs/formats.md)",
                    toml::Value::String(d.clone())
                );
            }
        }
        if let Some(p) = &self.projector {
            s.push_str("\n[projector]\n");
            let _ = writeln!(
                s,
                "rotation = [{}, {}, {}]  # R, rows: X_cam = R * X_proj + T",
                arr(&p.rotation[0]),
                arr(&p.rotation[1]),
                arr(&p.rotation[2])
            );
            let _ = writeln!(s, "translation = {}  # T, mm", arr(&p.translation));
            s.push('\n');
            camera_toml(&mut s, "projector.intrinsics", &p.intrinsics);
        }
        if let Some(r) = &self.projector_response {
            s.push_str(
                "\n[projector_response]  # light r(x) for pattern value x = code / full scale\n",
            );
            let _ = writeln!(
                s,
                "gamma = {}  # the closest power law x^gamma (for reading)",
                num(r.gamma)
            );
            let _ = writeln!(s, "levels = {}  # x, 0..1", arr(&r.levels));
            let _ = writeln!(s, "response = {}  # r(x), 0..1", arr(&r.response));
        }
        if let Some(n) = &self.sensor {
            s.push_str(
                "\n[sensor]  # the camera's read noise, from the reference plane's captures\n",
            );
            let _ = writeln!(s, "bits = {}  # of the images it was measured on", n.bits);
            let _ = writeln!(s, "noise = {}  # sigma of one sample, codes", num(n.noise));
        }
        if let Some(c) = &self.camera_covariance {
            let _ = writeln!(
                s,
                "\n[camera_covariance]  # of the camera's [{}], from its calibration",
                super::COVARIANCE_ORDER.join(", ")
            );
            s.push_str("matrix = [\n");
            for row in &c.matrix {
                let _ = writeln!(s, "  {},", arr(row));
            }
            s.push_str("]\n");
        }
        Ok(s)
    }
}

/// A float in TOML: Rust's shortest round-trip form (`{:?}` always has a `.` or an exponent).
fn num(v: f64) -> String {
    format!("{v:?}")
}

fn arr(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|&x| num(x)).collect();
    format!("[{}]", parts.join(", "))
}

fn toml_str(p: &Path) -> Result<String, String> {
    let s = p
        .to_str()
        .ok_or_else(|| format!("path {} is not valid UTF-8", p.display()))?;
    Ok(toml::Value::String(s.to_string()).to_string())
}

fn camera_toml(s: &mut String, table: &str, c: &CameraParams) {
    let _ = writeln!(s, "[{table}]");
    let _ = writeln!(s, "width = {}  # px", c.width);
    let _ = writeln!(s, "height = {}  # px", c.height);
    let _ = writeln!(s, "fx = {}  # px", num(c.fx));
    let _ = writeln!(s, "fy = {}  # px", num(c.fy));
    let _ = writeln!(
        s,
        "skew = {}  # alpha: u = fx*x + skew*fx*y + cx",
        num(c.skew)
    );
    let _ = writeln!(s, "cx = {}  # px", num(c.cx));
    let _ = writeln!(s, "cy = {}  # px", num(c.cy));
    let _ = writeln!(
        s,
        "distortion = {}  # [k1, k2, p1, p2, k3]",
        arr(&c.distortion.to_array())
    );
}
