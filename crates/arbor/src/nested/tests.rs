//! The nested tracer against the flat one on random rays through random
//! small DAGs: the same hits, bit for bit.

use std::sync::Arc;

use glam::{DMat4, DQuat, DVec3, Vec3};

use super::*;
use crate::flatten::{FlattenedScene, DEFAULT_MAX_PLACEMENTS};
use crate::load::default_shader;
use crate::load::MeshData;
use crate::scene::Scene;
use crate::surface::{Group, MeshSurface, Sphere, Surface};
use crate::tracer::{Tracer, TracerOptions};
use arbor_accel::{AccelKind, NoCounters};

/// SplitMix64 as a fixed sequence of numbers in [0, 1).
fn sequence(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as f64 / 2f64.powi(64)
    }
}

fn mesh(random: &mut impl FnMut() -> f64) -> Surface {
    let mut p = || Vec3::new(random() as f32, random() as f32, random() as f32) - 0.5;
    Surface::Mesh(MeshSurface {
        data: Arc::new(MeshData {
            positions: vec![p(), p(), p(), p()],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..MeshData::default()
        }),
        shader: default_shader(),
        two_sided: true,
        soft_terminator: false,
    })
}

/// A rotation, a non-uniform scale and a translation, as one group matrix.
fn placement(random: &mut impl FnMut() -> f64, spread: f64) -> DMat4 {
    let axis = DVec3::new(random() - 0.5, random() - 0.5, random() - 0.5 + 1e-3).normalize();
    let scale = DVec3::new(0.7 + random(), 0.7 + random(), 0.7 + random());
    let at = (DVec3::new(random(), random(), random()) - 0.5) * spread;
    DMat4::from_scale_rotation_translation(scale, DQuat::from_axis_angle(axis, 6.0 * random()), at)
}

/// A DAG of `levels` levels: each level places the one below 3 or 4 times,
/// under one or two nested groups, beside some geometry of its own.
fn dag(seed: u64, levels: usize) -> Scene {
    let mut random = sequence(seed);
    let mut below = Arc::new(mesh(&mut random));
    for level in 1..=levels {
        let spread = 1.5 * level as f64;
        let mut children: Vec<Surface> = (0..3 + (random() * 2.0) as usize)
            .map(|_| {
                let inner = Surface::Group(Group {
                    transform: placement(&mut random, 1.0),
                    children: vec![Surface::Instance(below.clone())],
                });
                Surface::Group(Group {
                    transform: placement(&mut random, spread),
                    children: vec![inner],
                })
            })
            .collect();
        if level % 2 == 0 {
            children.push(mesh(&mut random));
            children.push(Surface::Sphere(Sphere {
                center: DVec3::new(random(), random(), random()),
                radius: 0.2,
                shader: default_shader(),
            }));
        }
        below = Arc::new(Surface::Group(Group {
            transform: placement(&mut random, 1.0),
            children,
        }));
    }
    let mut scene = crate::default_scene::classroom();
    scene.surfaces = vec![
        Surface::Group(Group {
            transform: placement(&mut random, 2.0),
            children: vec![Surface::Instance(below.clone())],
        }),
        Surface::Instance(below),
        mesh(&mut random),
    ];
    scene
}

fn flat(scene: &Scene) -> Tracer {
    let flat = FlattenedScene::new(scene, DEFAULT_MAX_PLACEMENTS).unwrap();
    Tracer::build(flat, &TracerOptions::default())
}

/// Flat and nested hits on `ray`: the same `t`, point and normal, bit
/// for bit, and the same occlusion; whether it hit.
fn same_answers(flat: &Tracer, nested: &NestedTracer, ray: &Ray, what: &str) -> bool {
    let a = flat.closest(ray);
    let b = nested.closest_counted(ray, &mut NoCounters);
    assert_eq!(a.is_some(), b.is_some(), "{what}");
    if let (Some(a), Some(b)) = (a, b) {
        assert_eq!(a.t.to_bits(), b.t.to_bits(), "{what}");
        assert_eq!(a.point, b.point, "{what}");
        assert_eq!(a.normal, b.normal, "{what}");
        assert_eq!(a.shadow_offset, b.shadow_offset, "{what}");
        assert!(std::ptr::eq(a.shader, b.shader), "{what}");
    }
    let occluded = nested.occluded_counted(ray, &mut NoCounters);
    assert_eq!(flat.occluded(ray), occluded, "{what}");
    a.is_some()
}

/// Property: on random small DAGs (rotations and non-uniform scales at
/// every level, geometry beside references), nested closest and occluded
/// equal flat on random rays, for nested throughout, partly flattened and
/// wholly flattened levels, with the default structure and brute force.
#[test]
fn nested_answers_bit_for_bit_as_flat_on_random_dags() {
    let mut hits = 0;
    for seed in 0..6u64 {
        let scene = dag(seed, 2 + (seed % 3) as usize);
        let flat = flat(&scene);
        for (kind, flatten_budget) in [
            (TracerOptions::default().accel, 1),
            (AccelKind::List, 1),
            (TracerOptions::default().accel, 5),
            (AccelKind::BvhSah, u64::MAX),
        ] {
            let nested = build(&scene, kind, flatten_budget).unwrap();
            let mut random = sequence(seed + 100);
            let span = 8.0;
            for k in 0..1000 {
                let o = (DVec3::new(random(), random(), random()) - 0.5) * 2.0 * span;
                let aim = (DVec3::new(random(), random(), random()) - 0.5) * 3.0;
                let (tmin, tmax) = if k % 3 == 0 {
                    (1e-6, 0.7)
                } else {
                    (0.0, f64::INFINITY)
                };
                let ray = Ray::new(o, aim - o, tmin, tmax);
                let what = format!("seed {seed} {kind} {flatten_budget} ray {k}");
                hits += usize::from(same_answers(&flat, &nested, &ray, &what));
            }
        }
    }
    assert!(hits > 5000, "{hits} hits");
}

/// Coincident copies (the same definition placed twice at the same spot,
/// under different chains): every hit is a tie between placements, and
/// the nested tracer picks the one the flat tracer picks (the first
/// placed), whose shader differs.
#[test]
fn ties_between_placements_go_as_flat() {
    let mut random = sequence(3);
    let shader = |r: f64| {
        Arc::new(crate::shader::Shader::Lambertian {
            diffuse: DVec3::splat(r),
            texture: None,
        })
    };
    let Surface::Mesh(one) = mesh(&mut random) else {
        unreachable!()
    };
    // The same triangles under two shaders.
    let quad = |shader| {
        let mut m = one.clone();
        m.shader = shader;
        Arc::new(Surface::Mesh(m))
    };
    let (a, b) = (quad(shader(0.2)), quad(shader(0.8)));
    let pair = |first: &Arc<Surface>, second: &Arc<Surface>| {
        Arc::new(Surface::Group(Group {
            transform: DMat4::IDENTITY,
            children: vec![
                Surface::Instance(first.clone()),
                Surface::Instance(second.clone()),
                Surface::Instance(first.clone()),
            ],
        }))
    };
    let (ab, ba) = (pair(&a, &b), pair(&b, &a));
    // First placed: `b`; last: `a` (a search keeping the last tie fails).
    let mut scene = crate::default_scene::classroom();
    scene.surfaces = vec![
        Surface::Instance(ba.clone()),
        Surface::Instance(ab.clone()),
        Surface::Instance(ab),
    ];
    // (`ba` placed once is inlined: its copies of `b` come first.)
    let flat = flat(&scene);
    let nested = build(&scene, TracerOptions::default().accel, 1).unwrap();
    let mut hits = 0;
    for k in 0..500 {
        let o = DVec3::new(random() - 0.5, random() - 0.5, 3.0);
        let ray = Ray::new(o, DVec3::new(0.0, 0.0, -1.0), 0.0, f64::INFINITY);
        hits += usize::from(same_answers(&flat, &nested, &ray, &format!("ray {k}")));
    }
    assert!(hits > 20, "{hits} hits");
}

#[test]
fn each_definition_is_built_once() {
    // Four levels of 3-4 placements each: the flat tracer makes hundreds of
    // placements, the nested one the world plus one per level.
    let scene = dag(7, 4);
    let nested = build(&scene, TracerOptions::default().accel, 1).unwrap();
    assert_eq!(nested.definitions(), 1 + 5);
    assert_eq!(nested.depth(), 5);
    assert!(flat(&scene).placements() > 100);
}

#[test]
fn nesting_deeper_than_the_limit_is_refused() {
    let chain = |levels: usize| {
        let mut below = Arc::new(mesh(&mut sequence(1)));
        for _ in 1..levels {
            below = Arc::new(Surface::Group(Group {
                transform: DMat4::IDENTITY,
                children: vec![Surface::Instance(below.clone()), Surface::Instance(below)],
            }));
        }
        let mut scene = crate::default_scene::classroom();
        scene.surfaces = vec![mesh(&mut sequence(2)), Surface::Instance(below)];
        scene
    };
    let kind = TracerOptions::default().accel;
    assert_eq!(
        build(&chain(MAX_INSTANCE_LEVELS), kind, 1).unwrap().depth(),
        MAX_INSTANCE_LEVELS
    );
    let e = build(&chain(MAX_INSTANCE_LEVELS + 1), kind, 1)
        .err()
        .unwrap();
    assert!(matches!(e, NestError::TooDeep { depth: 33, .. }), "{e:?}");
    assert_eq!(
        e.to_string(),
        "top-level surface 2 (ref): references nest 33 deep from here; nested instancing follows at most 32"
    );
}

/// A group of `n` placements of `of`, 2 apart along x.
fn row(of: &Arc<Surface>, n: usize) -> Arc<Surface> {
    let children = (0..n)
        .map(|i| {
            Surface::Group(Group {
                transform: DMat4::from_translation(DVec3::new(2.0 * i as f64, 0.0, 0.0)),
                children: vec![Surface::Instance(of.clone())],
            })
        })
        .collect();
    Arc::new(Surface::Group(Group {
        transform: DMat4::IDENTITY,
        children,
    }))
}

/// `auto`'s first rule: flat while the picture casts a camera ray for
/// each copy (up to the cap), or for few copies; else nested with the
/// budget.
#[test]
fn auto_traces_flat_while_the_picture_has_a_ray_for_each_copy() {
    let ball = Arc::new(Surface::Sphere(Sphere {
        center: DVec3::ZERO,
        radius: 0.8,
        shader: default_shader(),
    }));
    let cube = |n| row(&row(&row(&ball, n), n), n);
    let scene = |copies_per_side, (w, h), sps| {
        let mut scene = crate::default_scene::classroom();
        scene.surfaces = vec![Surface::Instance(cube(copies_per_side))];
        (scene.width, scene.height, scene.samples_per_side) = (w, h, sps);
        scene
    };
    let nested = Plan::Nested {
        flatten_budget: AUTO_FLATTEN_BUDGET,
    };
    let auto = |s: &Scene| Instancing::Auto.plan(s);
    // 50^3 = 125,000 copies: flat at 640x480 (307,200 rays), nested at 320x240.
    assert_eq!(auto(&scene(50, (640, 480), 1)), Plan::Flat);
    assert_eq!(auto(&scene(50, (320, 240), 1)), nested);
    // Few copies: flat at any size.
    assert_eq!(auto(&scene(40, (8, 8), 1)), Plan::Flat);
    // 16 samples a pixel: four times the rays.
    assert_eq!(auto(&scene(50, (320, 240), 4)), Plan::Flat);
    // 128^3 = 2^21 copies: past the cap, nested however many rays.
    assert_eq!(auto(&scene(128, (4096, 4096), 4)), nested);
    let big = scene(128, (4096, 4096), 4);
    assert_eq!(auto_flat_at_most(&big), AUTO_FLAT_FOR_RAYS_AT_MOST);
    assert_eq!(
        Instancing::Nested.plan(&big),
        Plan::Nested { flatten_budget: 1 }
    );
    assert_eq!(Instancing::Flat.plan(&big), Plan::Flat);
}

/// The flatten budget's rule on a field of 2 x 10 x 10 balls: each level
/// takes in child definitions while their cost (placements there times
/// copies each) fits, and a level of geometry alone is always taken in.
#[test]
fn each_level_flattens_its_children_within_its_budget() {
    let group = row;
    let ball = Surface::Sphere(Sphere {
        center: DVec3::ZERO,
        radius: 0.8,
        shader: default_shader(),
    });
    let a = group(&Arc::new(ball), 10);
    let b = group(&a, 10);
    let mut scene = crate::default_scene::classroom();
    let beside = Surface::Group(Group {
        transform: DMat4::from_translation(DVec3::new(0.0, 0.0, 1.5)),
        children: vec![Surface::Instance(b.clone())],
    });
    scene.surfaces = vec![Surface::Instance(b), beside];
    let children = |budget| build(&scene, AccelKind::BvhSah, budget).unwrap().children();
    // Nested throughout: 2 placements of b, 10 of a in b, 10 balls in a.
    assert_eq!(children(1), 22);
    // b (cost 10 x 10) takes a in; the world (cost 2 x 100) does not take b.
    assert_eq!(children(100), 2 + 100);
    assert_eq!(children(199), 2 + 100);
    // The world takes everything in: the flat tracer's two levels.
    assert_eq!(children(200), 200);
    let flat = flat(&scene);
    let mut hits = 0;
    for budget in [1, 100, 200] {
        let nested = build(&scene, AccelKind::BvhSah, budget).unwrap();
        let mut random = sequence(budget);
        for k in 0..200 {
            let o = DVec3::new(38.0 * random() - 1.0, 5.0, 2.8 * random() - 0.6);
            let ray = Ray::new(o, DVec3::new(0.1, -1.0, 0.05), 0.0, f64::INFINITY);
            let what = format!("budget {budget} ray {k}");
            hits += usize::from(same_answers(&flat, &nested, &ray, &what));
        }
    }
    assert!(hits > 200, "{hits} hits");
}

/// The recorder sees what the tracer does: its hit is the tracer's (same
/// `t`, bit for bit), its counts and levels entered are what `RayCounts`
/// and `--stats` count, and the hit's path runs through levels it
/// reached, each entered before the hit.
#[test]
fn the_record_follows_the_traversal_to_the_hit() {
    let scene = dag(4, 3);
    let nested = build(&scene, TracerOptions::default().accel, 1).unwrap();
    let mut random = sequence(7);
    let mut hits = 0;
    for _ in 0..300 {
        let o = (DVec3::new(random(), random(), random()) - 0.5) * 16.0;
        let aim = (DVec3::new(random(), random(), random()) - 0.5) * 3.0;
        let ray = Ray::new(o, aim - o, 0.0, f64::INFINITY);
        let mut rec = NestedRecord::default();
        let hit = nested.closest_counted(&ray, &mut rec);
        let mut counts = arbor_accel::RayCounts::default();
        nested.closest_counted(&ray, &mut counts);
        assert_eq!(rec.counts, counts);
        let mut work = crate::stats::RayWork::default();
        nested.closest_counted(&ray, &mut work);
        assert_eq!(rec.entered, work.levels);
        assert_eq!(rec.levels[0].path, Vec::<u32>::new());
        assert_eq!(rec.levels[0].definition, nested.root());
        let entered = rec
            .levels
            .iter()
            .filter(|l| !l.path.is_empty() && !l.geometry);
        assert!(entered.count() as u64 <= rec.entered);
        match (hit, rec.hit()) {
            (None, None) => {}
            (Some(h), Some(r)) => {
                hits += 1;
                assert_eq!(h.t.to_bits(), r.t.to_bits());
                for depth in 0..=r.path.len() {
                    let prefix = &r.path[..depth];
                    let reached =
                        |l: &LevelReached| l.path == prefix && l.t.is_some_and(|t| t <= r.t);
                    assert!(rec.levels.iter().any(reached), "{prefix:?} {r:?}");
                }
            }
            (h, r) => panic!("tracer {:?} record {r:?}", h.map(|h| h.t)),
        }
    }
    assert!(hits > 30, "{hits} hits");
}

/// Every definition a child places and every child is traced back to the
/// scene: children to references (`Surface::Instance`), a definition to
/// one shared surface, the one its children's references point at; for
/// nested throughout, partly and wholly flattened levels.
#[test]
fn sources_name_the_scene_surfaces_behind_the_levels() {
    for seed in 0..4u64 {
        let scene = dag(seed, 2 + (seed % 3) as usize);
        let mut instances = std::collections::HashMap::new();
        fn visit(s: &Surface, out: &mut std::collections::HashMap<usize, usize>) {
            match s {
                Surface::Group(g) => g.children.iter().for_each(|c| visit(c, out)),
                Surface::Instance(inner) => {
                    out.insert(s as *const Surface as usize, Arc::as_ptr(inner) as usize);
                    visit(inner, out);
                }
                _ => {}
            }
        }
        scene.surfaces.iter().for_each(|s| visit(s, &mut instances));
        for flatten_budget in [1, 5, u64::MAX] {
            let nested = build(&scene, AccelKind::BvhSah, flatten_budget).unwrap();
            let sources = nested.sources(&scene).expect("sources");
            assert_eq!(sources.definitions[nested.root() as usize], None);
            for (d, children) in sources.children.iter().enumerate() {
                let summary = nested.summary(d as u32);
                for (c, at) in summary.children.iter().zip(children) {
                    let target = sources.definitions[c.definition as usize];
                    assert!(target.is_some(), "seed {seed} {flatten_budget}");
                    assert_eq!(Some(instances[at]), target);
                }
            }
        }
    }
}
