//! The reference pipeline's inputs (a rendered scene and its calibration) and its row drivers:
//! decode and reconstruct whole frames one row at a time, as a streaming head does.

use super::{DecodeStage, PointStage, VectorOptions, VectorsError, kernel};
use crate::io::calibration::Calibration;
use crate::render::scene::{Overrides, SceneSpec};
use crate::render::{RenderOptions, Scene, decode_phase_corrected};
use crate::scan::ScanCalibration;
use fringe3d_core::decode::{DecodeConfig, Decoder, PhaseCorrection, RowOut, Sample};
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::math::CANONICAL_NAN;
use fringe3d_core::reconstruct::compiled::{FIELDS, compiled_row, merge_search, search_mask};
use fringe3d_core::reconstruct::{Reconstructor, ReferenceMap, ReferenceRing};
use fringe3d_core::validity::Validity;
use std::path::{Path, PathBuf};

/// The reference pipeline's inputs, resolved: what [`generate`](super::generate) renders and what a test needs to
/// run other drivers (the desktop batch path) on the same data.
pub struct Inputs {
    /// The rendered scene.
    pub scene: Scene,
    /// Camera codes per image (set order), `width × height` each.
    pub images: Vec<Vec<u16>>,
    /// Significant bits of the camera codes.
    pub bits: u8,
    /// The calibration, reconstructor and prepared reference map.
    pub calibration: ScanCalibration,
    /// Decoder thresholds.
    pub decode_config: DecodeConfig,
    /// The edge filter.
    pub edge_filter: EdgeFilter,
    /// Its focal length, pixels (`min(fx, fy)`).
    pub edge_focal_px: f64,
    /// Its steepest accepted surface, degrees.
    pub edge_max_angle_deg: f64,
    /// The decoder's phase-error table for the projector's gamma, if any.
    pub correction: Option<PhaseCorrection>,
    /// Which reference map the calibration holds.
    pub reference: super::VectorReference,
    /// Compile the reconstruction too, to this tolerance, mm ([`super::VectorOptions::compiled`]).
    pub compiled: Option<f64>,
}

/// Render the scene of `opts` and set up its calibration (no decoding of the object yet).
pub fn inputs(opts: &VectorOptions) -> Result<Inputs, VectorsError> {
    let scenes = ["sphere", "ballbar", "steps", "freeform", "plane"];
    if !scenes.contains(&opts.scene.as_str()) {
        return Err(VectorsError::Options(format!(
            "scene {:?}: golden vectors use one of {}",
            opts.scene,
            scenes.join(", ")
        )));
    }
    let (w, h) = opts.size;
    if !(16..=4096).contains(&w) || !(16..=4096).contains(&h) {
        return Err(VectorsError::Options(format!(
            "size {w}x{h}: width and height must be 16 to 4096"
        )));
    }
    if !(opts.max_angle_deg > 0.0 && opts.max_angle_deg < 90.0) {
        return Err(VectorsError::Options(format!(
            "edge-filter angle {}: must be in (0, 90) degrees",
            opts.max_angle_deg
        )));
    }
    let o = Overrides {
        seed: opts.seed,
        noise: opts.noise,
        bits: opts.bits,
        size: Some(opts.size),
        defocus: opts.defocus,
        ..Overrides::default()
    };
    if let Some(g) = opts.gamma
        && !(g.is_finite() && g > 0.0 && g <= 10.0)
    {
        return Err(VectorsError::Options(format!(
            "gamma {g}: must be in (0, 10]"
        )));
    }
    let mut spec = SceneSpec::builtin(&opts.scene).map_err(crate::render::RenderError::from)?;
    spec.apply(&o);
    if let Some(g) = opts.gamma {
        spec.projector.gamma = g;
    }
    if let Some(p) = &opts.patterns {
        spec.patterns.set = Some(p.clone());
    }
    let scene = Scene::new(spec, None)?;
    let correction = scene.true_correction(&scene.patterns)?;
    let ropts = RenderOptions::default();
    let (frames, _truth) = scene.render_fringes(ropts)?;
    let (ref_frames, _) = scene.render_reference(ropts)?;
    let captured = decode_phase_corrected(&scene.patterns, &ref_frames, correction.as_ref())?;
    let digest = crate::io::calibration::pattern_digest(&scene.patterns)
        .map_err(|m| VectorsError::Options(format!("reference pattern set: {m}")))?;
    let mut cal = scene.rig.calibration(
        Some(PathBuf::from("reference_phase.tif")),
        Some(PathBuf::from("patterns.toml")),
        Some(digest),
    );
    let reference = match opts.reference {
        super::VectorReference::Captured => captured,
        super::VectorReference::Model => {
            crate::calib::reference_fit::fit_reference(
                &scene.patterns,
                &captured,
                w as usize,
                h as usize,
            )
            .map_err(|e| VectorsError::Options(format!("reference model: {e}")))?
            .phase
        }
        super::VectorReference::Virtual => virtual_map(
            &cal,
            &scene,
            (scene.rig.reference_point, scene.rig.reference_normal),
        )?,
        super::VectorReference::VirtualMargin => {
            use crate::calib::virtual_reference::{default_plane, margin_needed};
            let plane = default_plane(cal.depth_range);
            let margin = margin_needed(&cal, &scene.patterns, plane)
                .map_err(|e| VectorsError::Options(format!("virtual reference: {e}")))?;
            let reference = cal
                .reference
                .as_mut()
                .ok_or_else(|| VectorsError::Options("the rig has no reference plane".into()))?;
            (reference.point, reference.normal) = plane;
            reference.margin = Some(margin.to_array());
            virtual_map(&cal, &scene, plane)?
        }
    };
    // What the table of the set-up blob is made from, so that the folder's calibration.toml
    // gives `fringe3d scan` the same decoding as the head's blob.
    scene.record_true_light(&mut cal);
    let calibration = ScanCalibration::from_parts(
        cal,
        reference,
        scene.patterns.axis(),
        Path::new("input/calibration.toml"),
    )?;
    let edge_filter = calibration.edge_filter(opts.max_angle_deg)?;
    let c = &calibration.calibration.camera;
    let edge_focal_px = c.fx.min(c.fy);
    Ok(Inputs {
        images: frames.images,
        bits: frames.bits,
        decode_config: DecodeConfig::for_bit_depth(frames.bits as u32),
        scene,
        calibration,
        edge_filter,
        edge_focal_px,
        edge_max_angle_deg: opts.max_angle_deg,
        correction,
        reference: opts.reference,
        compiled: opts.compiled,
    })
}

/// Decode whole frames with the row APIs, one row at a time (the reference driver).
pub fn decode_rows<P: Sample>(
    dec: &Decoder,
    frames: &[&[P]],
    width: usize,
    height: usize,
) -> Result<DecodeStage, VectorsError> {
    let n = width * height;
    let levels = dec.level_count();
    // (A Gray-code level has no wrapped phase: its per-level planes stay empty.)
    let plane = |l: usize| {
        if dec.level_has_phase(l) {
            vec![0.0; n]
        } else {
            Vec::new()
        }
    };
    let mut s = DecodeStage {
        wrapped: (0..levels).map(plane).collect(),
        modulation_level: (0..levels).map(plane).collect(),
        dc: vec![0.0; n],
        modulation: vec![0.0; n],
        phase: vec![0.0; n],
        validity: vec![0; n],
    };
    if frames.len() != dec.image_count() || frames.iter().any(|f| f.len() != n) {
        return Err(kernel(
            "decode",
            "frame count or size differs from the pattern set and image size",
        ));
    }
    for y in 0..height {
        let r = y * width..(y + 1) * width;
        let rows: Vec<&[P]> = frames.iter().map(|f| &f[r.clone()]).collect();
        dec.decode_row(
            &rows,
            RowOut {
                phase: &mut s.phase[r.clone()],
                modulation: &mut s.modulation[r.clone()],
                dc: &mut s.dc[r.clone()],
                validity: &mut s.validity[r.clone()],
            },
        )
        .map_err(|e| kernel("decode", e))?;
        for l in (0..levels).filter(|&l| dec.level_has_phase(l)) {
            dec.decode_row_level(
                &rows,
                l,
                &mut s.wrapped[l][r.clone()],
                &mut s.modulation_level[l][r.clone()],
            )
            .map_err(|e| kernel("decode (per level)", e))?;
        }
    }
    Ok(s)
}

/// Reconstruct and edge-filter whole frames row by row through a [`ReferenceRing`] of exactly
/// the band's rows (the streaming driver a head runs), with a 3-row window for the filter.
pub fn reconstruct_rows(
    recon: &Reconstructor,
    reference_phase: &[f32],
    reference_validity: &[u8],
    phase: &[f32],
    validity: &[u8],
    filter: &EdgeFilter,
) -> Result<PointStage, VectorsError> {
    let (w, h) = (recon.width(), recon.height());
    let n = w * h;
    // The map's rows are its own width: the image's and its margin past the image.
    let (mw, mh) = (recon.map_width(), recon.map_height());
    if reference_phase.len() != mw * mh
        || reference_validity.len() != mw * mh
        || phase.len() != n
        || validity.len() != n
    {
        return Err(kernel("reconstruct", "map sizes differ from the camera"));
    }
    let band = recon.band().rows().min(mh as u32) as usize;
    let mut ring_phase = vec![0.0f32; band * mw];
    let mut ring_validity = vec![0u8; band * mw];
    let mut ring = ReferenceRing::new(recon, &mut ring_phase, &mut ring_validity)
        .map_err(|e| kernel("reconstruct", e))?;
    let mut out = PointStage {
        points: vec![0.0; 3 * n],
        validity: vec![0; n],
        filtered_validity: vec![0; n],
        filtered_points: vec![0.0; 3 * n],
    };
    for v in 0..h {
        let (_, last) = recon.rows_needed(v as u32);
        while ring.rows_pushed() <= last {
            let r = ring.rows_pushed() as usize * mw..(ring.rows_pushed() as usize + 1) * mw;
            ring.push_row(&reference_phase[r.clone()], &reference_validity[r])
                .map_err(|e| kernel("reconstruct (reference ring)", e))?;
        }
        let r = v * w..(v + 1) * w;
        recon
            .reconstruct_row(
                &ring,
                v as u32,
                &phase[r.clone()],
                &validity[r.clone()],
                &mut out.points[3 * v * w..3 * (v + 1) * w],
                &mut out.validity[r],
            )
            .map_err(|e| kernel("reconstruct", e))?;
    }
    for v in 0..h {
        let row = |k: usize| {
            (
                &out.points[3 * k * w..3 * (k + 1) * w],
                &out.validity[k * w..(k + 1) * w],
            )
        };
        let above = (v > 0).then(|| row(v - 1));
        let below = (v + 1 < h).then(|| row(v + 1));
        if !filter.filter_row(
            above,
            row(v),
            below,
            &mut out.filtered_validity[v * w..(v + 1) * w],
        ) {
            return Err(kernel("edge filter", "row lengths disagree"));
        }
    }
    out.filtered_points.copy_from_slice(&out.points);
    for (i, p) in out.filtered_points.chunks_exact_mut(3).enumerate() {
        if out.filtered_validity[i] != Validity::Valid as u8 {
            p.fill(CANONICAL_NAN);
        }
    }
    Ok(out)
}

/// The compiled reconstruction of whole frames row by row (docs/compiled.md), as a head runs it:
/// `compiled_row` over the row's models (`FIELDS × width` each, `models` row after row), then
/// for the pixels it leaves, the §6 search over the prepared map with every other pixel masked
/// (`search_mask`), merged in (`merge_search`). Returns the points, their codes and how many
/// pixels went to the search.
pub fn reconstruct_rows_compiled(
    recon: &Reconstructor,
    reference_phase: &[f32],
    models: &[f32],
    phase: &[f32],
    validity: &[u8],
) -> Result<(Vec<f32>, Vec<u8>, usize), VectorsError> {
    let stage = "compiled reconstruction";
    let (w, h) = (recon.width(), recon.height());
    let map = ReferenceMap::from_prepared(reference_phase, recon.map_width(), recon.map_height())
        .map_err(|e| kernel(stage, e))?;
    if models.len() != FIELDS * w * h || phase.len() != w * h || validity.len() != w * h {
        return Err(kernel(stage, "models or rows differ from the camera"));
    }
    let (z_min, z_max) = (recon.setup().z_min as f32, recon.setup().z_max as f32);
    let (mut xyz, mut codes) = (vec![0f32; 3 * w * h], vec![0u8; w * h]);
    let (mut mask, mut sx, mut sq) = (vec![0u8; w], vec![0f32; 3 * w], vec![0u8; w]);
    let mut searched = 0;
    for v in 0..h {
        let (r, r3) = (v * w..(v + 1) * w, 3 * v * w..3 * (v + 1) * w);
        let m = &models[FIELDS * v * w..FIELDS * (v + 1) * w];
        let (p, q) = (&phase[r.clone()], &validity[r.clone()]);
        let (o, oq) = (&mut xyz[r3], &mut codes[r]);
        let left = compiled_row(m, z_min, z_max, p, q, o, oq).map_err(|e| kernel(stage, e))?;
        if left > 0 {
            searched += left;
            search_mask(oq, q, &mut mask).map_err(|e| kernel(stage, e))?;
            recon
                .reconstruct_row(&map, v as u32, p, &mask, &mut sx, &mut sq)
                .map_err(|e| kernel(stage, e))?;
            merge_search(&sx, &sq, o, oq).map_err(|e| kernel(stage, e))?;
        }
    }
    Ok((xyz, codes, searched))
}

/// The virtual reference map of the rig's projector model on `plane` (its point and normal),
/// extending past the image by the margin `cal`'s reference records (none: image-sized).
fn virtual_map(
    cal: &Calibration,
    scene: &Scene,
    plane: ([f64; 3], [f64; 3]),
) -> Result<Vec<f32>, VectorsError> {
    let projector = cal
        .projector
        .as_ref()
        .ok_or_else(|| VectorsError::Options("the rig has no projector model".into()))?;
    let margin = cal
        .reference
        .as_ref()
        .map(|r| r.margin())
        .unwrap_or_default();
    crate::calib::virtual_reference::virtual_reference(
        &cal.camera,
        projector,
        &scene.patterns,
        plane,
        margin,
    )
    .map_err(|e| VectorsError::Options(format!("virtual reference: {e}")))
}
