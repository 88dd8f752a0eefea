//! HDR on the head (issue #19 item 4, protocol version 8): a glossy sphere whose highlight clips
//! at the exposure metered for the diffuse light (`examples/scenes/specular.toml`), rendered at
//! two exposures. The head's camera replays the render of each exposure it is triggered for
//! (trigger-width exposure, `ReplaySeries`); `device scan --exposures-us 10000,2500` makes the
//! head capture the set at both and fuse them per pixel as frames arrive
//! (`FrameDecoder::next_exposure`). Its phases and points equal, bit for bit, the desktop's
//! `fringe3d scan --hdr long short` (`load_exposures` → `decode`, reconstruction, edge filter),
//! and they hold the highlight's points that the single exposure loses to saturation.

use std::path::{Path, PathBuf};

use fringe3d::cli::common;
use fringe3d::io::image_set::ImageSet;
use fringe3d::render::dataset::{DatasetOptions, write_dataset};
use fringe3d::render::{Overrides, Scene};
use fringe3d::scan::{ScanCalibration, filter_edges};
use fringe3d_core::validity::Validity;
use fringe3d_core::wire::{EdgeFilterMode, Exposures, ScanOutput, ValidationStatus};

use crate::head_pty::{CAM, assert_desktop_bits, fresh_root, head_case_with, on_head_series};

/// The specular scene at the head tests' camera size, exposed `exposure` times the metered
/// light, with noise seed `seed`.
fn render(dir: &Path, exposure: f64, seed: u64) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes/specular.toml");
    let scene = Scene::load(
        &path,
        &Overrides {
            size: Some(CAM),
            supersample: Some(1),
            exposure: Some(exposure),
            seed: Some(seed),
            ..Default::default()
        },
    )
    .unwrap();
    let opts = DatasetOptions {
        overwrite: true,
        progress: None,
    };
    write_dataset(&scene, dir, opts).unwrap();
}

#[test]
fn an_hdr_scan_on_the_head_is_bit_identical_to_scan_hdr_and_keeps_the_highlight() {
    let root = fresh_root("hdr");
    let (long, short) = (root.join("long"), root.join("short"));
    render(&long, 1.0, 3);
    render(&short, 0.25, 7);
    let calib = long.join("calibration.toml");
    // The long exposure alone, as the head scans it without a list (the sequence's 10 ms).
    let case = head_case_with(&long, &calib);
    let saturated = |v: &[u8]| {
        v.iter()
            .filter(|&&c| c == Validity::Saturated as u8)
            .count()
    };
    let clipped = saturated(&case.dec.validity);
    assert!(
        clipped >= (CAM.0 * CAM.1) as usize / 100,
        "the highlight clips: {clipped} saturated pixels"
    );

    // The desktop's `scan --hdr long short`.
    let ls = common::load_set(&long.join("patterns.toml")).unwrap();
    let folders: Vec<PathBuf> = vec![long.clone(), short.clone()];
    let sc = ScanCalibration::load(&calib, ls.set.axis()).unwrap();
    let decode_cloud = |imgs: &ImageSet| {
        let cfg = common::decode_config(imgs);
        let dec = common::decode_corrected(&ls.set, imgs, cfg, case.table.as_ref()).unwrap();
        let mut cloud = sc.reconstruct(&dec.phase, &dec.validity, true).unwrap();
        filter_edges(&mut cloud, &sc.edge_filter(80.0).unwrap());
        (dec, cloud)
    };
    let (dec, cloud) = decode_cloud(&common::load_exposures(&ls, &folders, true).unwrap());
    // The short exposure alone.
    let one = common::load_images(&ls, std::slice::from_ref(&short), true).unwrap();
    let (short_dec, short_cloud) = decode_cloud(&one);
    let kept = clipped - saturated(&dec.validity);
    eprintln!(
        "{} x {}: {clipped} pixels saturated at the long exposure, {kept} resolved by the short; \
         {} points from the long exposure alone, {} fused",
        CAM.0,
        CAM.1,
        case.cloud.valid_count(),
        cloud.valid_count()
    );
    assert!(
        kept * 10 >= clipped * 9,
        "the short exposure resolves the highlight: {kept} of {clipped} saturated pixels"
    );
    assert!(
        cloud.valid_count() >= case.cloud.valid_count() + kept / 2,
        "HDR points {} against {} from the long exposure alone",
        cloud.valid_count(),
        case.cloud.valid_count()
    );

    let takes = vec![(10_000, long.clone()), (2_500, short.clone())];
    on_head_series(takes, &case, None, true, |c, v| {
        assert_eq!(v, ValidationStatus::OK);
        let scan = |c: &mut fringe3d::device::Client<_>, us: &[u32]| {
            c.scan_exposed(
                ScanOutput::Both,
                0,
                0,
                EdgeFilterMode::MaxAngle(80.0),
                Exposures::new(us).unwrap(),
                &mut |_, _| {},
            )
            .unwrap()
        };
        // Without a list, and with the sequence's own exposure as a list of one: the long
        // exposure alone.
        assert_desktop_bits(&scan(c, &[]), &case.dec, &case.cloud);
        assert_desktop_bits(&scan(c, &[10_000]), &case.dec, &case.cloud);
        // One shorter exposure: the short render alone.
        assert_desktop_bits(&scan(c, &[2_500]), &short_dec, &short_cloud);
        // HDR: the desktop's fusion, bit for bit.
        assert_desktop_bits(&scan(c, &[10_000, 2_500]), &dec, &cloud);
    });
    let _ = std::fs::remove_dir_all(&root);
}
