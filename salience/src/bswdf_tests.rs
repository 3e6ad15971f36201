//! Tests of the BSWDF evaluator: the documented properties, and agreement with a direct,
//! unoptimised transcription of the formula.

use super::*;
use crate::light::Light;
use crate::neighbours::NeighbourLists;
use proptest::prelude::*;

/// A `side × side` grid in the z = 0 plane, spacing `h`, centred on the origin, with
/// 8-neighbourhoods (structural and diagonal links).
fn grid(side: u32, h: f32) -> (Vec<Vec3>, NeighbourLists) {
    let c = (side - 1) as f32 * 0.5;
    let positions = (0..side * side)
        .map(|k| {
            Vec3::new(
                ((k % side) as f32 - c) * h,
                ((k / side) as f32 - c) * h,
                0.0,
            )
        })
        .collect();
    let mut edges = Vec::new();
    for y in 0..side {
        for x in 0..side {
            let k = y * side + x;
            if x + 1 < side {
                edges.push([k, k + 1]);
            }
            if y + 1 < side {
                edges.push([k, k + side]);
                if x + 1 < side {
                    edges.push([k, k + side + 1]);
                }
                if x > 0 {
                    edges.push([k, k + side - 1]);
                }
            }
        }
    }
    let lists = NeighbourLists::from_undirected_edges((side * side) as usize, &edges).unwrap();
    (positions, lists)
}

fn camera_at(z: f32) -> View {
    View::look_at(Vec3::new(0.0, 0.0, z), Vec3::ZERO, Vec3::Y, 1.0, 1280, 720).unwrap()
}

/// `view` lit by `light` (or unlit).
fn lit(view: &View, light: Option<&Light>) -> View {
    view.with_light(light.copied()).unwrap()
}

/// Evaluates every node of `nodes` seen by `view`.
fn run(
    view: &View,
    object: ObjectMotion,
    params: &BswdfParams,
    nodes: Nodes<'_>,
    lists: &NeighbourLists,
) -> Vec<f32> {
    let job = BswdfJob {
        view,
        object,
        params,
        nodes,
        neighbours: lists.as_neighbours(),
    };
    let mut out = vec![f32::NAN; nodes.positions.len()];
    evaluate(&job, &mut out).unwrap();
    out
}

/// Velocity field of a bump moving out of the plane at the grid's centre.
fn bump(positions: &[Vec3], amplitude: f32) -> Vec<Vec3> {
    positions
        .iter()
        .map(|p| Vec3::Y * amplitude * (-p.length_squared() / 0.02).exp())
        .collect()
}

#[test]
fn rigid_translation_has_no_local_motion() {
    let (positions, lists) = grid(9, 0.1);
    let params = BswdfParams::default();
    for v in [Vec3::ZERO, Vec3::X * 0.3, Vec3::new(2.0, -1.0, 0.5)] {
        let velocities = vec![v; positions.len()];
        let object = ObjectMotion::mean_of(&positions, &velocities).unwrap();
        let g = GlobalMotion::new(&camera_at(3.0), &object, &params);
        let out = run(
            &camera_at(3.0),
            object,
            &params,
            Nodes {
                positions: &positions,
                velocities: &velocities,
                normals: None,
            },
            &lists,
        );
        for s in out {
            assert!((s - g.base).abs() < 1e-6, "{s} vs base {}", g.base);
        }
    }
}

#[test]
fn a_node_moving_unlike_its_neighbours_scores_higher() {
    let (positions, lists) = grid(9, 0.1);
    let mut velocities = vec![Vec3::X * 0.2; positions.len()];
    let odd = 40; // the centre
    velocities[odd] = Vec3::Y * 0.3;
    let params = BswdfParams::default();
    let object = ObjectMotion::mean_of(&positions, &velocities).unwrap();
    let out = run(
        &camera_at(3.0),
        object,
        &params,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: None,
        },
        &lists,
    );
    let far_corner = 0;
    assert!(
        out[odd] > out[far_corner] + 0.1,
        "{} vs {}",
        out[odd],
        out[far_corner]
    );
    // Its neighbours see it too (their mean is disturbed), but less than it does.
    for &j in lists.as_neighbours().of(odd) {
        assert!(out[j as usize] > out[far_corner] && out[j as usize] < out[odd]);
    }
}

#[test]
fn farther_camera_gives_lower_salience() {
    let (positions, lists) = grid(9, 0.1);
    let velocities = bump(&positions, 0.5);
    let params = BswdfParams::default();
    let object = ObjectMotion::mean_of(&positions, &velocities).unwrap();
    let near = run(
        &camera_at(2.0),
        object,
        &params,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: None,
        },
        &lists,
    );
    let far = run(
        &camera_at(8.0),
        object,
        &params,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: None,
        },
        &lists,
    );
    let moving = near.iter().zip(&far).filter(|(n, _)| **n > 0.05).count();
    assert!(moving > 4, "the bump registers");
    for (n, f) in near.iter().zip(&far) {
        assert!(f <= n, "{f} > {n}");
    }
    assert!(far.iter().sum::<f32>() < 0.8 * near.iter().sum::<f32>());
}

#[test]
fn faster_object_lowers_the_cap() {
    let (positions, lists) = grid(9, 0.1);
    // A strongly moving node on a cloth that translates sideways at various speeds.
    let params = BswdfParams {
        global_base_max: 0.0,
        ..BswdfParams::default()
    };
    let centre = 40;
    let salience_at = |speed: f32| {
        let mut velocities = vec![Vec3::X * speed; positions.len()];
        velocities[centre] += Vec3::Y * 5.0;
        let object = ObjectMotion::mean_of(&positions, &velocities).unwrap();
        let out = run(
            &camera_at(3.0),
            object,
            &params,
            Nodes {
                positions: &positions,
                velocities: &velocities,
                normals: None,
            },
            &lists,
        );
        (
            out[centre],
            GlobalMotion::new(&camera_at(3.0), &object, &params).cap,
        )
    };
    let (still, cap0) = salience_at(0.0);
    let (slow, cap1) = salience_at(1.0);
    let (fast, cap2) = salience_at(6.0);
    assert!(cap0 > cap1 && cap1 > cap2);
    assert!(still > slow && slow > fast, "{still} {slow} {fast}");
    assert!((fast - cap2).abs() < 1e-6, "clamped to the cap");
}

#[test]
fn moving_object_is_more_salient_than_a_still_one() {
    let (positions, lists) = grid(5, 0.1);
    let params = BswdfParams::default();
    let still = vec![Vec3::ZERO; positions.len()];
    let moving = vec![Vec3::X * 0.5; positions.len()];
    let object = |v: &[Vec3]| ObjectMotion::mean_of(&positions, v).unwrap();
    let a = run(
        &camera_at(3.0),
        object(&still),
        &params,
        Nodes {
            positions: &positions,
            velocities: &still,
            normals: None,
        },
        &lists,
    );
    let b = run(
        &camera_at(3.0),
        object(&moving),
        &params,
        Nodes {
            positions: &positions,
            velocities: &moving,
            normals: None,
        },
        &lists,
    );
    assert!(a.iter().all(|&s| s == 0.0));
    assert!(b.iter().all(|&s| s > 0.0));
}

#[test]
fn back_facing_and_grazing_surfels_count_less() {
    let (positions, lists) = grid(9, 0.1);
    let velocities = bump(&positions, 0.5);
    let object = ObjectMotion::mean_of(&positions, &velocities).unwrap();
    let cam = camera_at(3.0);
    let n = positions.len();
    let eval = |normal: Vec3, sides: Sidedness| {
        let params = BswdfParams {
            sides,
            ..BswdfParams::default()
        };
        let normals = vec![normal; n];
        run(
            &cam,
            object,
            &params,
            Nodes {
                positions: &positions,
                velocities: &velocities,
                normals: Some(&normals),
            },
            &lists,
        )
    };
    let front = eval(Vec3::Z, Sidedness::OneSided);
    let back = eval(-Vec3::Z, Sidedness::OneSided);
    let grazing = eval(Vec3::new(1.0, 0.0, 0.15).normalize(), Sidedness::OneSided);
    let back_two = eval(-Vec3::Z, Sidedness::TwoSided);
    let none = run(
        &cam,
        object,
        &BswdfParams::default(),
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: None,
        },
        &lists,
    );
    let centre = 40;
    assert!(front[centre] > grazing[centre] && grazing[centre] > back[centre]);
    // Back-facing one-sided keeps the documented floor.
    let floor = BswdfParams::default().facing_floor;
    assert!((back[centre] - floor * none[centre]).abs() < 1e-6);
    // Two-sided: the back is as salient as the front, up to the off-axis cosine spread.
    for i in 0..n {
        assert!((back_two[i] - front[i]).abs() < 1e-6);
        assert!(front[i] <= none[i] + 1e-6);
    }
}

#[test]
fn light_multiplies() {
    let (positions, lists) = grid(9, 0.1);
    let velocities = bump(&positions, 0.5);
    let object = ObjectMotion::mean_of(&positions, &velocities).unwrap();
    let cam = camera_at(3.0);
    let params = BswdfParams::default();
    let normals: Vec<Vec3> = positions
        .iter()
        .map(|p| Vec3::new(p.x, 0.0, 1.0).normalize())
        .collect();
    let dark = run(
        &cam,
        object,
        &params,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: Some(&normals),
        },
        &lists,
    );
    let l = Vec3::new(1.0, 0.0, 1.0);
    let sun = Light::directional(l, 0.2, 0.8);
    let sunlit = run(
        &lit(&cam, Some(&sun)),
        object,
        &params,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: Some(&normals),
        },
        &lists,
    );
    for i in 0..positions.len() {
        let illu = 0.2 + 0.8 * normals[i].dot(l.normalize()).max(0.0);
        assert!((sunlit[i] - dark[i] * illu).abs() < 1e-6);
    }
    // A point light far along the same direction agrees with the directional light.
    let lamp = Light::point(l * 1.0e4, 0.2, 0.8);
    let lamp_lit = run(
        &lit(&cam, Some(&lamp)),
        object,
        &params,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: Some(&normals),
        },
        &lists,
    );
    for i in 0..positions.len() {
        assert!((lamp_lit[i] - sunlit[i]).abs() < 1e-4);
    }
    // Light from behind a two-sided surface leaves the seen side in ambient light.
    let two = BswdfParams {
        sides: Sidedness::TwoSided,
        ..params
    };
    let behind = Light::directional(-Vec3::Z, 0.3, 0.7);
    let flat = vec![Vec3::Z; positions.len()];
    let plain = run(
        &cam,
        object,
        &two,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: Some(&flat),
        },
        &lists,
    );
    let back_lit = run(
        &lit(&cam, Some(&behind)),
        object,
        &two,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: Some(&flat),
        },
        &lists,
    );
    for i in 0..positions.len() {
        assert!((back_lit[i] - 0.3 * plain[i]).abs() < 1e-6);
    }
}

#[test]
fn off_screen_nodes_keep_only_the_outside_weight() {
    let (positions, lists) = grid(9, 0.1);
    let velocities = bump(&positions, 0.5);
    let object = ObjectMotion::mean_of(&positions, &velocities).unwrap();
    let params = BswdfParams::default();
    let facing = run(
        &camera_at(3.0),
        object,
        &params,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: None,
        },
        &lists,
    );
    // Looking away from the cloth.
    let away = View::new(Vec3::new(0.0, 0.0, 3.0), Vec3::Z, Vec3::Y, 1.0, 1280, 720).unwrap();
    let out = run(
        &away,
        object,
        &params,
        Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: None,
        },
        &lists,
    );
    for (a, f) in out.iter().zip(&facing) {
        assert!((a - params.outside_view_weight * f).abs() < 1e-6);
    }
}

#[test]
fn isolated_nodes_move_relative_to_the_object() {
    let positions = [Vec3::ZERO, Vec3::X * 0.1];
    let lists = NeighbourLists::from_undirected_edges(2, &[]).unwrap();
    let velocities = [Vec3::Y, Vec3::Y];
    let params = BswdfParams {
        global_base_max: 0.0,
        ..BswdfParams::default()
    };
    let with = |v: Vec3| {
        let object = ObjectMotion {
            centre: Vec3::ZERO,
            velocity: v,
        };
        run(
            &camera_at(3.0),
            object,
            &params,
            Nodes {
                positions: &positions,
                velocities: &velocities,
                normals: None,
            },
            &lists,
        )
    };
    assert!(with(Vec3::Y).iter().all(|&s| s == 0.0));
    assert!(with(Vec3::ZERO).iter().all(|&s| s > 0.1));
}

#[test]
fn chunks_reproduce_the_whole_bit_for_bit() {
    let (positions, lists) = grid(17, 0.05);
    let velocities = bump(&positions, 0.7);
    let normals: Vec<Vec3> = positions
        .iter()
        .map(|p| (Vec3::Z + *p).normalize())
        .collect();
    let cam = camera_at(2.0);
    let params = BswdfParams::default();
    let light = Light::point(Vec3::new(1.0, 2.0, 1.0), 0.25, 0.75);
    let view = lit(&cam, Some(&light));
    let job = BswdfJob {
        view: &view,
        object: ObjectMotion::mean_of(&positions, &velocities).unwrap(),
        params: &params,
        nodes: Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: Some(&normals),
        },
        neighbours: lists.as_neighbours(),
    };
    let mut whole = vec![0.0; positions.len()];
    evaluate(&job, &mut whole).unwrap();
    let mut pieces = vec![0.0; positions.len()];
    let mut first = 0;
    for chunk in pieces.chunks_mut(37) {
        let len = chunk.len();
        evaluate_range(&job, first, chunk).unwrap();
        first += len;
    }
    assert_eq!(whole, pieces);
}

#[test]
fn errors_leave_the_output_untouched() {
    let (positions, lists) = grid(5, 0.1);
    let n = positions.len();
    let velocities = vec![Vec3::X; n];
    let normals = vec![Vec3::Z; n];
    let cam = camera_at(3.0);
    let params = BswdfParams::default();
    let sun = Light::directional(Vec3::Z, 0.3, 0.7);
    let sunny = lit(&cam, Some(&sun));
    let good = BswdfJob {
        view: &cam,
        object: ObjectMotion::default(),
        params: &params,
        nodes: Nodes {
            positions: &positions,
            velocities: &velocities,
            normals: Some(&normals),
        },
        neighbours: lists.as_neighbours(),
    };
    let sentinel = vec![-7.0f32; n];
    let mut out = sentinel.clone();

    let short = &velocities[1..];
    let bad_params = BswdfParams {
        facing_floor: f32::NAN,
        ..params
    };
    let cases: Vec<BswdfJob<'_>> = vec![
        BswdfJob {
            nodes: Nodes {
                velocities: short,
                ..good.nodes
            },
            ..good
        },
        BswdfJob {
            nodes: Nodes {
                normals: Some(&normals[2..]),
                ..good.nodes
            },
            ..good
        },
        BswdfJob {
            object: ObjectMotion {
                centre: Vec3::NAN,
                velocity: Vec3::ZERO,
            },
            ..good
        },
        BswdfJob {
            params: &bad_params,
            ..good
        },
        BswdfJob {
            view: &sunny,
            nodes: Nodes {
                normals: None,
                ..good.nodes
            },
            ..good
        },
    ];
    for job in &cases {
        assert!(evaluate(job, &mut out).is_err());
        assert_eq!(out, sentinel);
    }
    // A light too bright for [0, 1] cannot even be put into a view.
    let too_bright = Light::directional(Vec3::Z, 0.6, 0.6);
    assert!(cam.with_light(Some(too_bright)).is_err());
    // Wrong output length, wrong neighbour table, range past the end.
    let mut longer = vec![-7.0f32; n + 1];
    assert!(evaluate(&good, &mut longer).is_err());
    assert!(longer.iter().all(|&s| s == -7.0));
    let other = NeighbourLists::from_undirected_edges(n - 1, &[]).unwrap();
    let mismatched = BswdfJob {
        neighbours: other.as_neighbours(),
        ..good
    };
    assert!(matches!(
        evaluate(&mismatched, &mut out),
        Err(SalienceError::LengthMismatch {
            what: "neighbour table",
            ..
        })
    ));
    assert!(matches!(
        evaluate_range(&good, n - 3, &mut out[..5]),
        Err(SalienceError::RangeOutOfBounds { .. })
    ));
    assert_eq!(out, sentinel);
    // A NaN camera cannot even be built.
    assert!(
        View::new(
            Vec3::ZERO,
            Vec3::new(f32::NAN, 0.0, 1.0),
            Vec3::Y,
            1.0,
            8,
            8
        )
        .is_err()
    );
    // The good case succeeds and overwrites everything.
    evaluate(&good, &mut out).unwrap();
    assert!(out.iter().all(|s| (0.0..=1.0).contains(s)));
}

/// The documented formula, transcribed term by term through the public view measures and
/// curves, with none of the kernel's algebraic shortcuts.
fn reference(job: &BswdfJob<'_>, i: usize) -> f32 {
    let (p, cam, nodes, nb) = (job.params, job.view, &job.nodes, &job.neighbours);
    let g = GlobalMotion::new(cam, &job.object, p);
    let x = nodes.positions[i];
    let row = nb.of(i);
    let reference_velocity = if row.is_empty() {
        job.object.velocity
    } else {
        row.iter()
            .map(|&j| nodes.velocities[j as usize])
            .sum::<Vec3>()
            / row.len() as f32
    };
    let omega = cam
        .angular_speed(x, nodes.velocities[i] - reference_velocity)
        .to_degrees()
        * p.display_angle_scale;
    let mut s = g.combine(p.local_motion.response(omega));
    if !cam.is_in_view(x, p.view_margin) {
        s *= p.outside_view_weight;
    }
    if let Some(normals) = nodes.normals {
        let n = normals[i];
        let to_eye = (cam.position() - x).normalize();
        let cos = n.dot(to_eye);
        let c = match p.sides {
            Sidedness::OneSided => cos.max(0.0),
            Sidedness::TwoSided => cos.abs(),
        };
        s *= p.facing_floor + (1.0 - p.facing_floor) * c.min(1.0);
        if let Some(light) = cam.light() {
            let l = match light.source {
                LightSource::Directional { towards_light } => towards_light.normalize(),
                LightSource::Point { position } => (position - x).normalize_or_zero(),
            };
            let seen = if p.sides == Sidedness::TwoSided && cos < 0.0 {
                -n
            } else {
                n
            };
            s *= light.ambient + light.diffuse * seen.dot(l).clamp(0.0, 1.0);
        }
    }
    s.clamp(0.0, 1.0)
}

fn vec3(range: f32) -> impl Strategy<Value = Vec3> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn unit() -> impl Strategy<Value = Vec3> {
    vec3(1.0).prop_map(|v| v.try_normalize().unwrap_or(Vec3::Z))
}

prop_compose! {
    /// Random nodes, random (possibly empty, repeated, self-including) neighbour rows, a random
    /// camera, light, object motion and parameters.
    fn scene()(n in 1usize..40)(
        positions in prop::collection::vec(vec3(5.0), n),
        velocities in prop::collection::vec(vec3(20.0), n),
        normals in prop::collection::vec(unit(), n),
        rows in prop::collection::vec(prop::collection::vec(0u32..n as u32, 0..9), n),
        eye in vec3(10.0),
        look in unit(),
        fov in 0.1f32..3.0,
        light_kind in 0u8..3,
        light_v in vec3(10.0),
        ambient in 0.0f32..0.5,
        object_v in vec3(30.0),
        two_sided in any::<bool>(),
        base_max in 0.0f32..1.0,
        floor in 0.0f32..1.0,
        use_normals in any::<bool>(),
    ) -> (Vec<Vec3>, Vec<Vec3>, Option<Vec<Vec3>>, Vec<Vec<u32>>, View, ObjectMotion, BswdfParams) {
        let camera = View::new(eye, look, Vec3::new(0.3, 1.0, -0.2), fov, 640, 480)
            .or_else(|_| View::new(eye, look, Vec3::X, fov, 640, 480))
            .unwrap();
        let light = match (light_kind, use_normals) {
            (_, false) | (0, _) => None,
            (1, _) => Some(Light::directional(light_v + Vec3::Z * 0.01, ambient, 1.0 - ambient)),
            _ => Some(Light::point(light_v, ambient, 0.9 - ambient)),
        };
        let params = BswdfParams {
            sides: if two_sided { Sidedness::TwoSided } else { Sidedness::OneSided },
            global_base_max: base_max,
            facing_floor: floor,
            ..BswdfParams::default()
        };
        let object = ObjectMotion { centre: positions[0], velocity: object_v };
        let view = camera.with_light(light).unwrap();
        (positions, velocities, use_normals.then_some(normals), rows, view, object, params)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn random_scenes_stay_in_range_and_match_the_reference(
        (positions, velocities, normals, rows, view, object, params) in scene()
    ) {
        let mut offsets = vec![0u32];
        let mut indices = Vec::new();
        for row in &rows {
            indices.extend_from_slice(row);
            offsets.push(indices.len() as u32);
        }
        let nb = Neighbours::new(&offsets, &indices, positions.len()).unwrap();
        let job = BswdfJob {
            view: &view,
            object,
            params: &params,
            nodes: Nodes {
                positions: &positions,
                velocities: &velocities,
                normals: normals.as_deref(),
            },
            neighbours: nb,
        };
        let mut out = vec![f32::NAN; positions.len()];
        evaluate(&job, &mut out).unwrap();
        for (i, &s) in out.iter().enumerate() {
            prop_assert!(s.is_finite() && (0.0..=1.0).contains(&s), "node {i}: {s}");
            let r = reference(&job, i);
            prop_assert!((s - r).abs() < 2e-4, "node {i}: kernel {s} vs reference {r}");
        }
    }
}

#[test]
fn non_finite_node_data_gives_zero_not_nan() {
    let (positions, lists) = grid(5, 0.1);
    let mut velocities = vec![Vec3::X; positions.len()];
    let mut normals = vec![Vec3::Z; positions.len()];
    velocities[3] = Vec3::new(f32::NAN, 0.0, 0.0);
    normals[7] = Vec3::splat(f32::INFINITY);
    let mut moved = positions.clone();
    moved[12] = Vec3::splat(f32::NAN);
    let params = BswdfParams::default();
    let out = run(
        &camera_at(3.0),
        ObjectMotion::default(),
        &params,
        Nodes {
            positions: &moved,
            velocities: &velocities,
            normals: Some(&normals),
        },
        &lists,
    );
    assert!(out.iter().all(|s| (0.0..=1.0).contains(s)));
    assert_eq!(out[3], 0.0);
    assert_eq!(out[12], 0.0);
}
