//! The manifest's parameters besides the file list: conventions, scene, decoder thresholds,
//! pattern set with its estimators, calibration, reconstruction band, edge filter, pipeline.

use super::pipeline::Inputs;
use super::{Dtype, FORMAT, VERSION, VectorsError, kernel};
use fringe3d_core::decode::{Decoder, level_estimator};
use fringe3d_core::pattern::{Convention, PatternSet};
use fringe3d_core::phase_function::{Axis, Profile};
use fringe3d_core::validity::Validity;
use serde_json::json;

fn axis_name(a: Axis) -> &'static str {
    match a {
        Axis::Xi => "xi",
        Axis::Eta => "eta",
    }
}

fn hex32(v: f32) -> String {
    format!("0x{:08x}", v.to_bits())
}

pub(super) fn manifest_info(
    inp: &Inputs,
    set: &PatternSet,
    dec: &Decoder,
    sample: Dtype,
    levels: usize,
) -> Result<serde_json::Map<String, serde_json::Value>, VectorsError> {
    let recon = &inp.calibration.recon;
    let (w, h) = (recon.width(), recon.height());
    let spec = &inp.scene.spec;
    let f = set.function();
    let profile = match f.profile() {
        Profile::Linear { origin, slope } => {
            json!({"kind": "linear", "origin": origin, "slope": slope})
        }
        Profile::Knots(k) => {
            json!({"kind": "knots", "positions": k.positions(), "phases": k.phases(), "slopes": k.slopes()})
        }
    };
    let mut estimators = Vec::new();
    for (k, l) in set.levels().iter().enumerate() {
        if let Some(g) = l.gray() {
            estimators.push(json!({
                "level": k,
                "gray_bits": g.bits(),
                "complementary": g.complementary(),
                "shifted": g.is_shifted(),
            }));
            continue;
        }
        let e = level_estimator(l.shifts(), set.effective_offset())
            .ok_or_else(|| kernel("decoder set-up", format!("level {k}: degenerate shifts")))?;
        let n = e.n;
        estimators.push(json!({
            "level": k,
            "a": e.a[..n].iter().map(|v| hex32(*v)).collect::<Vec<_>>(),
            "b": e.b[..n].iter().map(|v| hex32(*v)).collect::<Vec<_>>(),
            "w": e.w[..n].iter().map(|v| hex32(*v)).collect::<Vec<_>>(),
            "a_dc": hex32(e.a_dc),
            "b_dc": hex32(e.b_dc),
        }));
    }
    let c = inp.decode_config;
    let cam = recon.camera();
    let i = cam.params();
    let s = recon.setup();
    let band = recon.band();
    let v3 = |v: fringe3d_core::geometry::Vec3| json!([v.x, v.y, v.z]);
    let mut m = serde_json::Map::new();
    m.insert("format".into(), json!(FORMAT));
    m.insert("version".into(), json!(VERSION));
    m.insert(
        "generator".into(),
        json!(format!("fringe3d {}", env!("CARGO_PKG_VERSION"))),
    );
    m.insert(
        "conventions".into(),
        json!({
            "byte_order": "little-endian",
            "array_order": "C (row-major): the last index of `shape` varies fastest; images are [image, row, column], points [row, column, xyz]",
            "nan": "every NaN in every f32 file is the canonical quiet NaN 0x7fc00000; compare bits after mapping any NaN to it",
            "units": "phase radians, intensities camera codes, lengths mm (camera frame, OpenCV axes: x right, y down, z forward), pixel centres at integers",
            "hex_floats": "values written as 0x........ are the IEEE 754 binary32 bit patterns",
        }),
    );
    m.insert(
        "scene".into(),
        json!({"name": spec.name, "width": w, "height": h, "camera_bits": inp.bits, "noise_sigma": spec.camera.noise, "seed": spec.seed,
               "reference": inp.reference.name(),
               "compiled_tolerance_mm": inp.compiled,
               "regenerate": format!("fringe3d vectors --out DIR --scene {} --size {w}x{h} --bits {} --noise {} --seed {} --max-angle {} --reference {}{}",
                                     spec.name, inp.bits, spec.camera.noise, spec.seed, inp.edge_max_angle_deg, inp.reference.name(),
                                     inp.compiled.map_or(String::new(), |t| format!(" --compiled {}", t * 1e3)))}),
    );
    m.insert("sample_dtype".into(), json!(sample.name()));
    m.insert(
        "decode_config".into(),
        json!({"dark_level": hex32(c.dark_level), "saturation_level": hex32(c.saturation_level), "min_modulation": hex32(c.min_modulation),
               "unwrap_tolerance": hex32(c.unwrap_tolerance), "range_tolerance": hex32(c.range_tolerance),
               "values": [c.dark_level, c.saturation_level, c.min_modulation, c.unwrap_tolerance, c.range_tolerance]}),
    );
    m.insert(
        "pattern_set".into(),
        json!({
            "axis": axis_name(f.axis()),
            "profile": profile,
            "curvature": f.curvature(),
            "bend_center": f.bend_center(),
            "levels": set.levels().iter().map(|l| match l.gray() {
                // A Gray-code level: its code, no shifts and no wrapped-phase files.
                Some(g) => json!({"scale": l.scale(), "gray_bits": g.bits(), "complementary": g.complementary(), "shifted": g.is_shifted()}),
                None => json!({"scale": l.scale(), "shifts": l.shifts()}),
            }).collect::<Vec<_>>(),
            "output": {"width": set.output().width, "height": set.output().height, "i_min": set.output().i_min, "i_max": set.output().i_max},
            "convention": match set.convention() { Convention::Sine => "sine", Convention::Cosine => "cosine" },
            "phase_offset": set.phase_offset(),
            "effective_offset": set.effective_offset(),
            "order": set.order().iter().map(|id| json!([id.level, id.shift])).collect::<Vec<_>>(),
            "coarse_range": [set.coarse_range().0, set.coarse_range().1],
            "estimators": estimators,
            "images": dec.image_count(),
            "levels_count": levels,
        }),
    );
    m.insert(
        "calibration".into(),
        json!({
            "camera": {"fx": i.fx, "fy": i.fy, "skew": i.skew, "u0": i.cx, "v0": i.cy, "width": i.width, "height": i.height,
                       "distortion_k1_k2_p1_p2_k3": cam.distortion().to_array()},
            "projector_centre": v3(s.projector_centre),
            "reference_point": v3(s.reference_point),
            "reference_normal": v3(s.reference_normal),
            "axis": axis_name(s.axis),
            "depth_range": [s.z_min, s.z_max],
        }),
    );
    m.insert(
        "reconstruction".into(),
        json!({"band": {"above": band.above, "below": band.below, "rows": band.rows()},
               "margin_left_top_right_bottom": recon.margin().to_array(),
               "map_size": [recon.map_width(), recon.map_height()],
               "ring_bytes": recon.ring_bytes(band.rows()),
               "max_segment_px": recon.max_segment_px(),
               "fallback_bisections": recon.fallback_bisections()}),
    );
    m.insert(
        "edge_filter".into(),
        json!({"focal_px": inp.edge_focal_px, "max_angle_deg": inp.edge_max_angle_deg}),
    );
    m.insert(
        "validity_codes".into(),
        json!(
            Validity::ALL
                .iter()
                .map(|v| json!([*v as u8, v.name()]))
                .collect::<Vec<_>>()
        ),
    );
    m.insert(
        "pipeline".into(),
        json!([
            "decode: for every row y, Decoder::new(pattern_set, decode_config) (.with_correction(table) when input/setup.bin carries the projector-response table).decode_row(rows y of every image) -> phase, modulation, dc, validity; decode_row_level(rows, k) -> wrapped_level{k}, modulation_level{k}",
            "reconstruct: Reconstructor::new(camera, setup).with_margin(reconstruction.margin_left_top_right_bottom) (the map is reconstruction.map_size: the image and its margin past it; sample (i, j) at pixel (i - left, j - top)); a ReferenceRing of band.rows map rows (pushed in order from the map's top, invalid samples as canonical NaN); reconstruct_row(ring, v, phase row, validity row) -> points, validity",
            "edge filter: EdgeFilter::new(focal_px, max_angle_deg).filter_row(row above, row, row below) on the reconstructed points and codes -> filter/validity; points whose filtered code != 0 become canonical NaN",
        ]),
    );
    Ok(m)
}
