//! Instancing: `<defs>` and `ref` build a DAG; flattening keeps shared
//! geometry shared; the picture is the same as with every instance copied.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use arbor::flatten::{FlatGeometry, FlattenError, FlattenedScene};
use arbor::load::xml::parse_scene;
use arbor::render::render;
use arbor::scene::Scene;
use arbor::tracer::{Tracer, TracerOptions};
use arbor_accel::AccelKind;
use glam::DVec3;

mod support;
use support::hit_from_plus_x;

fn load(xml: &str) -> Scene {
    parse_scene(xml, Path::new("t.xml"))
        .unwrap_or_else(|e| panic!("{e}"))
        .scene
}

fn load_err(xml: &str) -> String {
    parse_scene(xml, Path::new("t.xml"))
        .unwrap_err()
        .to_string()
}

fn pixels(scene: &Scene, tracer: &Tracer) -> Vec<u8> {
    render(scene, tracer, &|_| {}, &AtomicBool::new(false))
        .unwrap()
        .to_rgb8(scene.variant)
}

/// The same picture with instances shared (two levels) and copied (one level).
fn assert_same_picture(scene: &Scene) {
    for kind in [AccelKind::DEFAULT, AccelKind::List] {
        let shared = Tracer::build(
            FlattenedScene::new(scene, 1 << 20).unwrap(),
            &TracerOptions::with_accel(kind),
        );
        let copied = Tracer::build(
            FlattenedScene::from_world(FlatGeometry::new(scene).unwrap()),
            &TracerOptions::with_accel(kind),
        );
        assert!(pixels(scene, &shared) == pixels(scene, &copied), "{kind}");
    }
}

const HEAD: &str = r#"<scene><camera><viewPoint>0 3 12</viewPoint><viewDir>0 -3 -12</viewDir><projDistance>2</projDistance></camera><image>48 36</image>
<light><position>4 8 6</position></light>"#;

/// Three levels: a ball and a box make a "pair", pairs make a "row"
/// (defined before the pair it uses: any order inside defs), rows a "field".
const NESTED: &str = r#"<defs>
  <surface type="Group" name="row">
    <surface type="Group"><translate>-2 0 0</translate><surface ref="pair"/></surface>
    <surface type="Group"><translate>0 0 0</translate><rotate>0 40 0</rotate><surface ref="pair"/></surface>
    <surface type="Group"><translate>2 0 0</translate><scale>1 1.5 1</scale><surface ref="pair"/></surface>
  </surface>
  <surface type="Group" name="pair">
    <surface type="Sphere"><center>0 0.5 0</center><radius>0.5</radius><shader type="Phong"><diffuseColor>0.8 0.3 0.2</diffuseColor></shader></surface>
    <surface type="Box"><minPt>-0.3 0 0.6</minPt><maxPt>0.3 0.3 0.9</maxPt></surface>
  </surface>
</defs>
<surface type="Group"><translate>0 0 -2</translate><surface ref="row"/></surface>
<surface type="Group"><translate>0 0 1</translate><rotate>0 -10 0</rotate><surface ref="row"/></surface>
<surface type="Box"><minPt>-5 -0.1 -5</minPt><maxPt>5 0 5</maxPt></surface>
</scene>"#;

#[test]
fn nested_definitions_share_geometry_and_render_like_copies() {
    let scene = load(&format!("{HEAD}{NESTED}"));
    let flat = FlattenedScene::new(&scene, 100).unwrap();
    // One shared geometry (the pair: 2 primitives), placed 2 rows x 3 = 6 times;
    // the row holds no geometry of its own; the floor stays in world space.
    assert_eq!(flat.shared.len(), 1);
    assert_eq!(flat.placements.len(), 6);
    assert_eq!(flat.unique_primitives(), 3);
    assert_eq!(flat.instanced_primitives(), 13);
    assert_same_picture(&scene);
}

#[test]
fn placement_limit_is_checked_before_allocating() {
    let scene = load(&format!("{HEAD}{NESTED}"));
    assert_eq!(
        FlattenedScene::new(&scene, 5).unwrap_err(),
        FlattenError::TooManyPlacements { count: 6, limit: 5 }
    );
}

#[test]
fn named_rendered_surface_can_be_placed_again() {
    let scene = load(&format!(
        r#"{HEAD}<surface type="Sphere" name="ball"><radius>0.7</radius></surface>
        <surface type="Group"><translate>2 0 0</translate><surface ref="ball"/></surface></scene>"#
    ));
    let flat = FlattenedScene::new(&scene, 100).unwrap();
    assert_eq!((flat.world.len(), flat.placements.len()), (0, 2));
    assert_same_picture(&scene);
}

#[test]
fn definition_used_once_is_baked_into_world_space() {
    let scene = load(&format!(
        r#"{HEAD}<defs><surface type="Sphere" name="ball"/></defs>
        <surface type="Group"><translate>1 0 0</translate><surface ref="ball"/></surface></scene>"#
    ));
    let flat = FlattenedScene::new(&scene, 100).unwrap();
    assert_eq!(
        (flat.world.len(), flat.shared.len(), flat.placements.len()),
        (1, 0, 0)
    );
    let (lo, hi) = flat.world.bounds(0);
    assert!(((lo + hi) / 2.0 - DVec3::X).length() < 1e-12);
}

#[test]
fn cycles_are_errors_naming_their_members() {
    let err = load_err(&format!(
        r#"{HEAD}<defs>
        <surface type="Group" name="a"><surface ref="b"/></surface>
        <surface type="Group" name="b"><surface ref="c"/></surface>
        <surface type="Group" name="c"><surface ref="a"/></surface>
        </defs></scene>"#
    ));
    assert!(
        err.contains("definitions form a cycle: a -> b -> c -> a"),
        "{err}"
    );
    assert!(err.starts_with("t.xml:3:9: "), "{err}");
}

#[test]
fn defs_entries_need_names_and_refs_outside_defs_need_earlier_definitions() {
    let err = load_err(&format!(
        r#"{HEAD}<defs><surface type="Sphere"/></defs></scene>"#
    ));
    assert!(err.contains("needs a name="), "{err}");
    let err = load_err(&format!(
        r#"{HEAD}<surface ref="late"/><defs><surface type="Sphere" name="late"/></defs></scene>"#
    ));
    assert!(err.contains("no element named 'late'"), "{err}");
}

#[test]
fn mirrored_placement_keeps_outward_normals() {
    let scene = load(&format!(
        r#"{HEAD}<defs><surface type="Sphere" name="ball"/></defs>
        <surface type="Group"><translate>3 0 0</translate><scale>-1 1 1</scale><surface ref="ball"/></surface>
        <surface type="Group"><translate>-3 0 0</translate><surface ref="ball"/></surface></scene>"#
    ));
    let tracer = Tracer::build(
        FlattenedScene::new(&scene, 100).unwrap(),
        &TracerOptions::default(),
    );
    let hit = hit_from_plus_x(&tracer, 0.0);
    assert!((hit.point.x - 4.0).abs() < 1e-12);
    assert!((hit.normal - DVec3::X).length() < 1e-12, "{:?}", hit.normal);
}

#[test]
fn the_default_scene_is_instanced_and_renders_like_copies() {
    let scene = arbor::default_scene::classroom();
    let flat = FlattenedScene::new(&scene, 100).unwrap();
    assert_eq!(flat.placements.len(), 12);
    let mut small = scene.clone();
    small.width = 64;
    small.height = 40;
    small.samples_per_side = 1;
    assert_same_picture(&small);
}

#[test]
fn bounded_surfaces_skip_work_and_change_nothing() {
    use arbor::tracer::BoundingVolumeKind;
    let scene = load(&format!(
        r#"{HEAD}<surface type="Group"><rotate>0 30 0</rotate>
             <surface type="Box"><minPt>-3 0 0</minPt><maxPt>-2 1 1</maxPt></surface>
             <surface type="Sphere"><center>-2 2 0</center><radius>0.5</radius></surface></surface>
           <surface type="Sphere"><center>2 1 0</center></surface>
           <surface type="Group"><scale>2 0.5 1</scale><surface type="Sphere"><center>0 -1 -2</center></surface></surface>
           </scene>"#
    ));
    let reference = pixels(
        &scene,
        &Tracer::build(
            FlattenedScene::from_world(FlatGeometry::new(&scene).unwrap()),
            &TracerOptions::with_accel(AccelKind::List),
        ),
    );
    for volume in [
        BoundingVolumeKind::Sphere,
        BoundingVolumeKind::Aabb,
        BoundingVolumeKind::Obb,
    ] {
        for kind in [AccelKind::List, AccelKind::DEFAULT] {
            let flat = FlattenedScene::bounded(&scene, 100).unwrap();
            assert_eq!(flat.objects.len(), 3);
            let tracer = Tracer::build(
                flat,
                &TracerOptions {
                    accel: kind,
                    bounding_volume: Some(volume),
                },
            );
            assert!(pixels(&scene, &tracer) == reference, "{volume:?} {kind}");
            let v = tracer.volume_stats();
            let tests = v.tests.load(std::sync::atomic::Ordering::Relaxed);
            let misses = v.misses.load(std::sync::atomic::Ordering::Relaxed);
            assert!(
                tests > 0 && misses <= tests,
                "{volume:?} {kind}: {tests} {misses}"
            );
            // Brute force offers every object to every ray: the volumes must
            // turn many away. (A BVH culls by boxes first, so they may not.)
            if kind == AccelKind::List {
                assert!(misses > tests / 4, "{volume:?}: {misses} of {tests}");
            }
        }
    }
}

/// The census (counting over the DAG) agrees with flattening (which
/// enumerates placements) on every instanced scene here and the default.
#[test]
fn census_counts_agree_with_flattening() {
    use arbor::census::Census;
    let mut scenes = vec![
        load(&format!("{HEAD}{NESTED}")),
        arbor::default_scene::classroom(),
        load(&format!(
            r#"{HEAD}<surface type="Sphere" name="ball"><radius>0.7</radius></surface>
            <surface type="Group"><translate>2 0 0</translate><surface ref="ball"/></surface></scene>"#
        )),
        load(&format!(
            r#"{HEAD}<defs><surface type="Sphere" name="ball"/></defs>
            <surface type="Group"><translate>1 0 0</translate><surface ref="ball"/></surface></scene>"#
        )),
    ];
    let mut two_thousand_fifteen = load(&format!("{HEAD}{NESTED}"));
    two_thousand_fifteen.variant = arbor::scene::Variant::Cornell2015;
    scenes.push(two_thousand_fifteen);
    for scene in &scenes {
        let flat = FlattenedScene::new(scene, 1 << 20).unwrap();
        let census = Census::new(&scene.surfaces, scene.variant).unwrap();
        assert_eq!(census.unique_primitives, flat.unique_primitives() as u128);
        assert_eq!(census.placements, flat.placements.len() as u128);
        assert_eq!(
            census.placed_primitives,
            flat.instanced_primitives() as u128
        );
    }
}
