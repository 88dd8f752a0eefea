//! The built-in scenes ([`BUILTIN_SCENES`](super::BUILTIN_SCENES)): the default rig with spheres, a
//! cylinder, a ball bar, steps, a freeform surface, a tilted plane, the reference plane alone, a
//! checkerboard and the calibration plates.

use super::super::light::ProjectorMode;
use super::super::math::{Mat3, Vec3};
use super::super::objects::{ObjectSpec, Shape};
use super::super::rig::{DEFAULT_AIM, default_rig};
use super::SceneSpec;
use super::sections::*;
use std::collections::BTreeMap;

/// The scene of `default_rig()` with no objects.
fn base(name: &str) -> SceneSpec {
    let rig = default_rig();
    let p = &rig.projector;
    SceneSpec {
        name: name.into(),
        kind: DatasetKind::Fringe,
        seed: 0,
        depth_range: rig.depth_range,
        volume: None,
        camera: CameraSpec::from_lens(&rig.camera),
        projector: ProjectorSpec {
            lens: *p,
            center: rig.translation,
            look_at: Some(DEFAULT_AIM),
            rotation: None,
            mode: ProjectorMode::Pixelated,
            defocus: d_defocus(),
            gamma: 1.0,
            black_level: 0.0,
            response: None,
            gray_levels: 0,
            bits: 16,
            unknown: BTreeMap::new(),
        },
        patterns: PatternSpec::default(),
        photometry: PhotometrySpec::default(),
        reference: ReferenceSpec {
            point: rig.reference_point,
            normal: rig.reference_normal,
            albedo: d_albedo(),
            mode: ReferenceMode::Render,
        },
        objects: Vec::new(),
        board: None,
        plates: None,
    }
}

fn obj(name: &str, albedo: f64, shape: Shape) -> ObjectSpec {
    ObjectSpec {
        name: name.into(),
        albedo,
        shape,
        texture: None,
        specular: None,
    }
}

fn background() -> ObjectSpec {
    obj(
        "background",
        0.6,
        Shape::Plane {
            point: [0.0, 0.0, 725.0],
            normal: [0.0, 0.0, -1.0],
            size: None,
            u_axis: None,
        },
    )
}

pub(super) fn builtin(name: &str) -> Option<SceneSpec> {
    let mut s = base(name);
    match name {
        "plane" => {
            let n = Mat3::from_euler_deg([12.0, -18.0, 0.0]).mul_vec(Vec3::new(0.0, 0.0, -1.0));
            s.objects.push(obj(
                "plane",
                0.8,
                Shape::Plane {
                    point: [0.0, 0.0, 600.0],
                    normal: n.to_array(),
                    size: None,
                    u_axis: None,
                },
            ));
        }
        "sphere" => {
            s.objects.push(obj(
                "sphere",
                0.8,
                Shape::Sphere {
                    center: [10.0, -5.0, 590.0],
                    radius: 60.0,
                },
            ));
            s.objects.push(background());
        }
        "cylinder" => {
            // A cylinder lying across the volume, its axis tilted out of the image plane.
            s.objects.push(obj(
                "cylinder",
                0.8,
                Shape::Cylinder {
                    center: [0.0, 10.0, 615.0],
                    axis: [1.0, 0.15, 0.25],
                    radius: 45.0,
                    length: 220.0,
                    caps: true,
                },
            ));
            s.objects.push(background());
        }
        "ballbar" => {
            s.objects.push(obj(
                "ballbar",
                0.8,
                Shape::BallBar {
                    center_a: [-95.0, -40.0, 620.0],
                    center_b: [95.0, 35.0, 570.0],
                    radius: 20.0,
                    bar_radius: 6.0,
                },
            ));
            s.objects.push(background());
        }
        "steps" => {
            // A base plate with five blocks of increasing height separated by 10 mm gaps, the
            // whole assembly tilted about the volume centre.
            let pose = Pose {
                center: [0.0, 0.0, 650.0],
                euler_deg: [6.0, -10.0, 4.0],
            };
            let place = |c: [f64; 3]| pose.apply(Vec3::new(c[0], c[1], c[2] - 650.0)).to_array();
            s.objects.push(obj(
                "base",
                0.75,
                Shape::Box {
                    center: place([0.0, 0.0, 705.0]),
                    size: [300.0, 230.0, 20.0],
                    euler_deg: pose.euler_deg,
                },
            ));
            let heights = [15.0, 35.0, 60.0, 90.0, 125.0];
            for (i, hgt) in heights.iter().enumerate() {
                let x = -110.0 + 55.0 * i as f64;
                let c = [x, 0.0, 695.0 - 0.5 * hgt];
                s.objects.push(obj(
                    &format!("step{}", i + 1),
                    0.8,
                    Shape::Box {
                        center: place(c),
                        size: [45.0, 170.0, *hgt],
                        euler_deg: pose.euler_deg,
                    },
                ));
            }
        }
        "freeform" => {
            s.objects.push(obj(
                "freeform",
                0.8,
                Shape::HeightField {
                    center: [0.0, 0.0, 660.0],
                    euler_deg: [190.0, -8.0, 0.0],
                    size: [270.0, 210.0],
                    base: 0.0,
                    bumps: vec![
                        [0.0, 0.0, 60.0, 45.0],
                        [-80.0, 50.0, 35.0, 25.0],
                        [85.0, -45.0, 40.0, 30.0],
                        [70.0, 60.0, -25.0, 22.0],
                        [-75.0, -55.0, 20.0, 18.0],
                        [20.0, -70.0, 15.0, 12.0],
                    ],
                },
            ));
        }
        "reference" => {
            s.objects.push(obj(
                "reference",
                d_albedo(),
                Shape::Plane {
                    point: s.reference.point,
                    normal: s.reference.normal,
                    size: None,
                    u_axis: None,
                },
            ));
            s.reference.mode = ReferenceMode::Images;
        }
        "checkerboard" => {
            s.kind = DatasetKind::Checkerboard;
            s.reference.mode = ReferenceMode::None;
            s.seed = 1;
            s.board = Some(BoardSpec {
                square: 25.0,
                cols: 11,
                rows: 8,
                dark: d_dark(),
                light: d_light(),
                margin: d_margin(),
                count: d_count(),
                poses: Vec::new(),
                supersample: d_board_ss(),
            });
        }
        "plates" => {
            s.kind = DatasetKind::Plates;
            s.board = Some(plate_board());
            let e = [8.0, -12.0, 0.0];
            s.plates = Some(PlatesSpec {
                size: [420.0, 340.0],
                albedo: 0.8,
                positions: vec![
                    Pose {
                        center: [0.0, 0.0, 710.0],
                        euler_deg: e,
                    },
                    Pose {
                        center: [0.0, 0.0, 600.0],
                        euler_deg: e,
                    },
                    Pose {
                        center: [0.0, 0.0, 490.0],
                        euler_deg: e,
                    },
                ],
            });
        }
        "boards" => {
            // The projector's calibration from freely posed boards (issue #18 item 2): a plates
            // data set whose "plates" are the board tilted by up to 25° about both axes, at
            // depths across the measurement volume (each pose: v/, h/ and board.png).
            s.kind = DatasetKind::Plates;
            s.board = Some(plate_board());
            let pose = |c: [f64; 3], e: [f64; 3]| Pose {
                center: c,
                euler_deg: e,
            };
            s.plates = Some(PlatesSpec {
                size: [330.0, 270.0],
                albedo: 0.8,
                positions: vec![
                    pose([0.0, 0.0, 700.0], [20.0, 3.0, 5.0]),
                    pose([10.0, 5.0, 690.0], [-20.0, 5.0, -5.0]),
                    pose([0.0, 10.0, 650.0], [2.0, 25.0, 0.0]),
                    pose([-10.0, 0.0, 630.0], [5.0, -25.0, 10.0]),
                    pose([-25.0, 15.0, 580.0], [15.0, 20.0, -3.0]),
                    pose([25.0, -15.0, 560.0], [-15.0, -20.0, -10.0]),
                    pose([0.0, 0.0, 600.0], [22.0, -15.0, 4.0]),
                    pose([0.0, 5.0, 530.0], [-10.0, 12.0, 20.0]),
                ],
            });
        }
        _ => return None,
    }
    Some(s)
}

/// The 9 × 7 board of 30 mm squares printed on the calibration plates (plates and boards scenes).
fn plate_board() -> BoardSpec {
    BoardSpec {
        square: 30.0,
        cols: 9,
        rows: 7,
        dark: d_dark(),
        light: d_light(),
        margin: d_margin(),
        count: 0,
        poses: Vec::new(),
        supersample: d_board_ss(),
    }
}
