//! Run the reference pipeline and collect every file of the vectors (nothing is written here).

use super::manifest::manifest_info;
use super::pipeline::{Inputs, decode_rows, inputs, reconstruct_rows, reconstruct_rows_compiled};
use super::setup::setup_bytes;
use super::{Dtype, GoldenVectors, VectorFile, VectorOptions, VectorsError, f32_bytes, file_err};
use super::{kernel, u16_bytes};
use crate::io::image::encode_tiff_f32;
use fringe3d_core::decode::Decoder;
use fringe3d_core::math::CANONICAL_NAN;
use fringe3d_core::wire::ReferenceFile;
use std::path::Path;

/// Render, run the reference pipeline and collect every file (nothing is written).
pub fn generate(opts: &VectorOptions) -> Result<GoldenVectors, VectorsError> {
    generate_from(&inputs(opts)?)
}

/// Run the reference pipeline on rendered inputs and collect every file (nothing is written).
pub fn generate_from(inp: &Inputs) -> Result<GoldenVectors, VectorsError> {
    let set = inp.scene.patterns;
    let cal = &inp.calibration;
    let recon = &cal.recon;
    let (w, h) = (recon.width(), recon.height());
    let mut dec = Decoder::new(&set, inp.decode_config).map_err(|e| kernel("decoder set-up", e))?;
    if let Some(c) = &inp.correction {
        dec = dec
            .with_correction(c)
            .map_err(|e| kernel("decoder set-up", e))?;
    }
    // 8-bit cameras get u8 files and the u8 kernel; deeper ones u16.
    let (sample, image_bytes, d) = if inp.bits == 8 {
        let f8: Vec<Vec<u8>> = inp
            .images
            .iter()
            .map(|f| f.iter().map(|&x| x.min(255) as u8).collect())
            .collect();
        let r: Vec<&[u8]> = f8.iter().map(|f| f.as_slice()).collect();
        let d = decode_rows(&dec, &r, w, h)?;
        (Dtype::U8, f8.concat(), d)
    } else {
        let r: Vec<&[u16]> = inp.images.iter().map(|f| f.as_slice()).collect();
        let d = decode_rows(&dec, &r, w, h)?;
        (
            Dtype::U16,
            inp.images.iter().flat_map(|f| u16_bytes(f)).collect(),
            d,
        )
    };
    let p = reconstruct_rows(
        recon,
        &cal.reference_phase,
        &cal.reference_validity,
        &d.phase,
        &d.validity,
        &inp.edge_filter,
    )?;

    let n_img = set.image_count();
    let levels = dec.level_count();
    let mut files = Vec::new();
    let mut arr =
        |path: String, dtype: Dtype, shape: Vec<usize>, description: String, bytes: Vec<u8>| {
            files.push(VectorFile {
                path,
                array: Some((dtype, shape)),
                format: "raw",
                description,
                bytes,
            });
        };
    arr(
        format!("input/images.{}", sample.name()),
        sample,
        vec![n_img, h, w],
        format!(
            "camera codes ({} significant bits) of every image of the set, in the set's image order (see pattern_set.order)",
            inp.bits
        ),
        image_bytes,
    );
    arr(
        "input/reference_phase.f32".into(),
        Dtype::F32,
        vec![recon.map_height(), recon.map_width()],
        "reference-plane absolute phase map Phi_R (radians), prepared: canonical NaN where invalid; the image and its margin past it (reconstruction.margin_left_top_right_bottom)"
            .into(),
        f32_bytes(&cal.reference_phase),
    );
    for l in (0..levels).filter(|&l| dec.level_has_phase(l)) {
        arr(
            format!("decode/wrapped_level{l}.f32"),
            Dtype::F32,
            vec![h, w],
            format!(
                "wrapped phase of level {l} (0 = coarsest), radians in [-pi, pi], every pixel (Decoder::decode_row_level)"
            ),
            f32_bytes(&d.wrapped[l]),
        );
        arr(
            format!("decode/modulation_level{l}.f32"),
            Dtype::F32,
            vec![h, w],
            format!(
                "modulation B of level {l}, camera codes, every pixel (Decoder::decode_row_level)"
            ),
            f32_bytes(&d.modulation_level[l]),
        );
    }
    arr(
        "decode/dc.f32".into(),
        Dtype::F32,
        vec![h, w],
        "DC term A (eq 10/15), camera codes, every pixel".into(),
        f32_bytes(&d.dc),
    );
    arr(
        "decode/modulation.f32".into(),
        Dtype::F32,
        vec![h, w],
        "modulation B of the finest level, camera codes, every pixel (Decoder::decode_row)".into(),
        f32_bytes(&d.modulation),
    );
    arr(
        "decode/phase.f32".into(),
        Dtype::F32,
        vec![h, w],
        "unwrapped absolute phase of the finest level (c_K * Phi), radians; canonical NaN where validity != 0".into(),
        f32_bytes(&d.phase),
    );
    arr(
        "decode/validity.u8".into(),
        Dtype::U8,
        vec![h, w],
        "decode validity codes (see validity_codes)".into(),
        d.validity.clone(),
    );
    arr(
        "reconstruct/points.f32".into(),
        Dtype::F32,
        vec![h, w, 3],
        "point M = (x, y, z) per pixel, camera frame, mm (paper eqs 16-18); canonical NaN where validity != 0".into(),
        f32_bytes(&p.points),
    );
    arr(
        "reconstruct/validity.u8".into(),
        Dtype::U8,
        vec![h, w],
        "reconstruction validity codes".into(),
        p.validity.clone(),
    );
    arr(
        "filter/validity.u8".into(),
        Dtype::U8,
        vec![h, w],
        "validity after the edge filter (valid points at a depth discontinuity become 10 = depth-edge, those beside a pixel without light 12 = light-edge)".into(),
        p.filtered_validity.clone(),
    );
    arr(
        "filter/points.f32".into(),
        Dtype::F32,
        vec![h, w, 3],
        "points after the edge filter: canonical NaN where the filtered validity != 0".into(),
        f32_bytes(&p.filtered_points),
    );
    // The compiled reconstruction (docs/compiled.md): the models, then the scan through them.
    let compiled = if let Some(tolerance) = inp.compiled {
        let (file, _) = crate::compiled::compile(recon, &cal.reference_phase, tolerance);
        let ph = &cal.reference_phase;
        let (xyz, codes, _) =
            reconstruct_rows_compiled(recon, ph, &file.models, &d.phase, &d.validity)?;
        arr(
            "compiled/points.f32".into(),
            Dtype::F32,
            vec![h, w, 3],
            "points of the compiled reconstruction (compiled_row, the search for the pixels it leaves, merge_search); canonical NaN where validity != 0".into(),
            f32_bytes(&xyz),
        );
        arr(
            "compiled/validity.u8".into(),
            Dtype::U8,
            vec![h, w],
            "validity codes of the compiled reconstruction".into(),
            codes,
        );
        Some(file)
    } else {
        None
    };
    if let Some(file) = compiled {
        files.push(VectorFile {
            path: "input/compiled.f3c".into(),
            array: None,
            format: "fringe3d compiled reconstruction (docs/formats.md): a 72-byte header, then 40 x width bytes per row",
            description: "one depth function of the phase per pixel (fringe3d compile to the manifest's scene.compiled_tolerance_mm; its source digest is zero: not tied to the folder's files), read row by row by a head".into(),
            bytes: file.to_bytes(),
        });
    }
    // The same map as a head stores it: versioned, sized, CRC-checked, samples 32 bytes in.
    let rf = ReferenceFile::of(recon);
    let mut map_file = vec![0u8; rf.file_len()];
    rf.emit(&cal.reference_phase, &mut map_file)
        .map_err(|e| kernel("reference map file", e))?;
    files.push(VectorFile {
        path: "input/reference.f3m".into(),
        array: None,
        format: "fringe3d reference map file v1 (docs/setup-blob.md): a 32-byte header, the samples of reference_phase.f32, a CRC-32C",
        description: "the reference map as a head stores it (flash, a file): checked at boot by wire::ReferenceFile::check_for; the samples, 32 bytes in, are read in place".into(),
        bytes: map_file,
    });
    files.push(VectorFile {
        path: "input/setup.bin".into(),
        array: None,
        format: "fringe3d head set-up blob v6 (docs/setup-blob.md)",
        description: "the core's head set-up blob (fringe3d_core::wire::setup): pattern set, capture order, decoder thresholds, camera model, reconstruction set-up, edge filter, phase-error table and the reference map's margin, versioned and CRC-checked, for firmware and ports".into(),
        bytes: setup_bytes(inp, &set, &dec)?,
    });
    let tif = encode_tiff_f32(
        Path::new("input/reference_phase.tif"),
        recon.map_width() as u32,
        recon.map_height() as u32,
        &canonical_vec(&cal.reference_phase),
    )
    .map_err(|e| file_err(Path::new("input/reference_phase.tif"), e))?;
    files.push(VectorFile {
        path: "input/reference_phase.tif".into(),
        array: None,
        format: "tiff gray float32 (NaN = invalid)",
        description: "the reference map as the calibration file names it (same values as reference_phase.f32)".into(),
        bytes: tif,
    });
    files.sort_by(|a, b| a.path.cmp(&b.path));

    let info = manifest_info(inp, &set, &dec, sample, levels)?;
    Ok(GoldenVectors {
        width: w,
        height: h,
        files,
        info,
    })
}

fn canonical_vec(v: &[f32]) -> Vec<f32> {
    v.iter()
        .map(|x| if x.is_nan() { CANONICAL_NAN } else { *x })
        .collect()
}
