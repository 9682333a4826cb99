//! Features no shared reference image covers, checked on small scenes of our
//! own against values worked out by hand from the spec's formulas.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use arbor::film::Film;
use arbor::flatten::{FlatGeometry, FlattenedScene};
use arbor::load::xml::parse_scene;
use arbor::ray::Ray;
use arbor::render::render;
use arbor::scene::{Scene, Variant};
use arbor::tracer::{Tracer, TracerOptions};
use glam::DVec3;

mod support;
use support::hit_from_plus_x;

fn load(xml: &str) -> Scene {
    parse_scene(xml, Path::new("test.xml"))
        .unwrap_or_else(|e| panic!("{e}"))
        .scene
}

fn film(scene: &Scene) -> Film {
    let tracer = Tracer::build(
        FlattenedScene::from_world(FlatGeometry::new(scene).unwrap()),
        &TracerOptions::default(),
    );
    render(scene, &tracer, &|_| {}, &AtomicBool::new(false)).unwrap()
}

fn close(a: DVec3, b: DVec3, eps: f64) -> bool {
    (a - b).abs().max_element() <= eps
}

const CAM_2015: &str = r#"<camera type="PerspectiveCamera"><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>2</projDistance></camera><image>21 21</image>"#;

#[test]
fn variant_is_told_by_the_camera_type() {
    let s = load(&format!("<scene>{CAM_2015}</scene>"));
    assert_eq!(s.variant, Variant::Cornell2015);
    let s = load("<scene><camera/><image>2 2</image></scene>");
    assert_eq!(s.variant, Variant::Cornell2010);
}

#[test]
fn rgb_normals_show_the_normal_facing_the_camera() {
    let s = load(&format!(
        r#"<scene>{CAM_2015}<surface type="Sphere"><shader type="RGBNormals"/></surface></scene>"#
    ));
    // The centre ray hits the sphere head-on: n = (0,0,1) -> colour (0.5,0.5,1).
    assert!(close(film(&s).get(10, 10), DVec3::new(0.5, 0.5, 1.0), 1e-9));
}

#[test]
fn directional_light_has_no_falloff_and_point_light_has_inverse_square() {
    // A big box face at z = 0 seen head-on; light straight along the normal.
    let body = |light: &str| {
        format!(
            r#"<scene>{CAM_2015}<surface type="Box"><shader type="Lambertian"><diffuseColor>0.5 0.5 0.5</diffuseColor></shader><minPt>-10 -10 -1</minPt><maxPt>10 10 0</maxPt></surface>{light}</scene>"#
        )
    };
    let s = load(&body(
        r#"<light type="DirectionalLight"><direction>0 0 1</direction><intensity>0.8 0.8 0.8</intensity></light>"#,
    ));
    assert!(close(film(&s).get(10, 10), DVec3::splat(0.4), 1e-9));
    let s = load(&body(
        r#"<light type="PointLight"><position>0 0 2</position><intensity>8 8 8</intensity></light>"#,
    ));
    // E = 8 / 2^2 = 2; kd * E * cos = 0.5 * 2 * 1.
    assert!(close(film(&s).get(10, 10), DVec3::splat(1.0), 1e-9));
}

/// A spot light lights what lies inside its cone and nothing outside it,
/// falling off as `1/r²` on its axis.
#[test]
fn spot_light_lights_its_cone_only() {
    use arbor::light::Light;
    let mut s = load(&format!(
        r#"<scene>{CAM_2015}<surface type="Box"><shader type="Lambertian"><diffuseColor>0.5 0.5 0.5</diffuseColor></shader><minPt>-10 -10 -1</minPt><maxPt>10 10 0</maxPt></surface></scene>"#
    ));
    s.lights = vec![Light::Spot {
        position: DVec3::new(0.0, 0.0, 2.0),
        direction: DVec3::NEG_Z,
        intensity: DVec3::splat(8.0),
        cos_inner: 0.1f64.cos(),
        cos_outer: 0.2f64.cos(),
    }];
    let f = film(&s);
    // On the axis: E = 8 / 2², kd E = 1.
    assert!(close(f.get(10, 10), DVec3::ONE, 1e-9), "{}", f.get(10, 10));
    // A corner of the picture lies far outside a 0.2 radian cone.
    assert_eq!(f.get(0, 0), DVec3::ZERO);
}

/// A Reflective surface (glTF's smooth metal) shows what its mirror
/// direction sees, weighted by its reflectance: here the background,
/// straight back along the camera ray.
#[test]
fn reflective_surfaces_mirror_what_they_face() {
    use arbor::shader::Shader;
    use arbor::surface::Surface;
    use std::sync::Arc;
    let mut s = load(&format!(
        r#"<scene><backColor>0.2 0.4 0.6</backColor>{CAM_2015}<surface type="Box"><shader type="Lambertian"><diffuseColor>0 0 0</diffuseColor></shader><minPt>-10 -10 -1</minPt><maxPt>10 10 0</maxPt></surface></scene>"#
    ));
    let Surface::Box(b) = &mut s.surfaces[0] else {
        panic!("a box");
    };
    b.shader = Arc::new(Shader::Reflective {
        reflectance: DVec3::new(1.0, 0.5, 0.0),
        substrate: b.shader.clone(),
    });
    let f = film(&s);
    // Head-on, Schlick's weight is the reflectance itself.
    assert!(
        close(f.get(10, 10), DVec3::new(0.2, 0.2, 0.0), 1e-9),
        "{}",
        f.get(10, 10)
    );
}

/// Model meshes with interpolated normals lift their shadow rays off the
/// flat triangles (the shadow terminator, `arbor::terminator`); meshes
/// without the flag (the course's scenes) and flat normals do not.
#[test]
fn soft_terminator_offsets_shadow_rays_of_smooth_meshes_only() {
    use arbor::load::MeshData;
    use arbor::surface::{MeshSurface, Surface};
    use glam::Vec3;
    use std::sync::Arc;
    let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
    // Normals leaning outward, as on a coarse sphere.
    let bulge = vec![
        Vec3::new(-1.0, -1.0, 2.0).normalize(),
        Vec3::new(1.0, 0.0, 2.0).normalize(),
        Vec3::new(0.0, 1.0, 2.0).normalize(),
    ];
    let offset = |soft: bool, normals: Vec<Vec3>| {
        let mut scene = load("<scene><camera/><image>2 2</image></scene>");
        scene.surfaces.push(Surface::Mesh(MeshSurface {
            data: Arc::new(MeshData {
                positions: positions.clone(),
                normals: Some(normals),
                uvs: None,
                colors: None,
                triangles: vec![[0, 1, 2]],
            }),
            shader: Arc::new(arbor::shader::Shader::default_lambertian()),
            two_sided: true,
            soft_terminator: soft,
        }));
        let tracer = Tracer::build(
            FlattenedScene::from_world(FlatGeometry::new(&scene).unwrap()),
            &TracerOptions::default(),
        );
        let o = DVec3::new(0.3, 0.3, 1.0);
        let hit = tracer
            .closest(&Ray::new(o, DVec3::NEG_Z, 0.0, f64::INFINITY))
            .unwrap();
        hit.shadow_offset
    };
    let lifted = offset(true, bulge.clone());
    assert!(lifted.z > 0.0, "{lifted}");
    assert_eq!(offset(false, bulge), DVec3::ZERO);
    assert_eq!(offset(true, vec![Vec3::Z; 3]), DVec3::ZERO);
}

#[test]
fn exposure_and_background() {
    let s = load(&format!(
        "<scene><exposure>2</exposure><backColor>0.1 0.2 0.3</backColor>{CAM_2015}</scene>"
    ));
    assert!(close(film(&s).get(0, 0), DVec3::new(0.2, 0.4, 0.6), 1e-12));
}

#[test]
fn parallel_camera_keeps_sizes() {
    // A sphere of radius 1 seen through a 4-unit-wide parallel view covers
    // half the width whatever its distance.
    for z in ["0", "-20"] {
        let s = load(&format!(
            r#"<scene><camera type="ParallelCamera"><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><viewWidth>4</viewWidth><viewHeight>4</viewHeight></camera><image>40 40</image>
            <surface type="Sphere"><center>0 0 {z}</center><shader type="RGBNormals"/></surface></scene>"#
        ));
        let f = film(&s);
        let covered = (0..40).filter(|&x| f.get(x, 20) != DVec3::ZERO).count();
        assert_eq!(covered, 20, "z = {z}");
    }
}

#[test]
fn cylinder_is_capped_and_stands_along_z() {
    let s = load(&format!(
        r#"<scene>{CAM_2015}<surface type="Cylinder"><radius>0.5</radius><height>4</height><shader type="RGBNormals"/></surface></scene>"#
    ));
    // Looking down the z axis we see the top cap: normal (0,0,1).
    assert!(close(film(&s).get(10, 10), DVec3::new(0.5, 0.5, 1.0), 1e-9));
    let side = load(&format!(
        r#"<scene>{CAM_2015}<surface type="Group"><rotate>90 0 0</rotate><surface type="Cylinder"><radius>0.5</radius><height>4</height><shader type="RGBNormals"/></surface></surface></scene>"#
    ));
    // Rotated to lie along y, the centre ray meets the side head-on.
    assert!(close(
        film(&side).get(10, 10),
        DVec3::new(0.5, 0.5, 1.0),
        1e-9
    ));
}

#[test]
fn group_transform_order_differs_between_variants() {
    // translate then scale, in document order.
    let group = r#"<surface type="Group"><translate>1 0 0</translate><scale>2 2 2</scale><surface type="Sphere"><radius>0.1</radius></surface></surface>"#;
    let bounds = |camera: &str| {
        let s = load(&format!("<scene>{camera}<image>2 2</image>{group}</scene>"));
        let flat = FlatGeometry::new(&s).unwrap();
        let (lo, hi) = flat.bounds(0);
        (lo + hi) / 2.0
    };
    // 2010: G = T * S, the scale applies first: centre stays at x = 1.
    assert!(close(bounds("<camera/>"), DVec3::new(1.0, 0.0, 0.0), 1e-12));
    // 2015: G = S * T, the translate applies first: centre moves to x = 2.
    assert!(close(
        bounds(r#"<camera type="PerspectiveCamera"/>"#),
        DVec3::new(2.0, 0.0, 0.0),
        1e-12
    ));
}

#[test]
fn named_values_can_be_referenced() {
    let s = load(
        r#"<scene><camera/><image>2 2</image>
        <surface type="Group"><rotate name="r">0 0 90</rotate><surface type="Box"><minPt>0 0 0</minPt><maxPt>2 1 1</maxPt></surface></surface>
        <surface type="Group"><rotate ref="r"/><surface type="Box"><minPt>0 0 0</minPt><maxPt>2 1 1</maxPt></surface></surface></scene>"#,
    );
    let flat = FlatGeometry::new(&s).unwrap();
    assert_eq!(flat.len(), 2);
    let (a, b) = (flat.bounds(0), flat.bounds(1));
    assert!(close(a.0, b.0, 1e-12) && close(a.1, b.1, 1e-12));
    // Rotated 90 degrees about z, the long side now runs along y.
    assert!(close(a.1 - a.0, DVec3::new(1.0, 2.0, 1.0), 1e-12));
}

#[test]
fn transformed_sphere_is_the_analytic_ellipsoid() {
    // Sphere squashed to an ellipsoid with semi-axes (2, 1, 1): a ray along x
    // from far away hits at x = 2.
    let s = load(
        r#"<scene><camera/><image>2 2</image><surface type="Group"><scale>2 1 1</scale><surface type="Sphere"/></surface></scene>"#,
    );
    let tracer = Tracer::build(
        FlattenedScene::from_world(FlatGeometry::new(&s).unwrap()),
        &TracerOptions::default(),
    );
    let hit = hit_from_plus_x(&tracer, 0.0);
    assert!((hit.point.x - 2.0).abs() < 1e-12);
    assert!(close(hit.normal, DVec3::X, 1e-12));
    // Off-axis: normal from the inverse transpose, (x/4, y, z) normalised.
    let y = 0.6;
    let hit = hit_from_plus_x(&tracer, y);
    let x = 2.0 * (1.0 - y * y).sqrt();
    assert!((hit.point.x - x).abs() < 1e-12);
    let expected = DVec3::new(x / 4.0, y, 0.0).normalize();
    assert!(close(hit.normal, expected, 1e-12));
}

#[test]
fn glass_2015_renders_finite_colours() {
    let s = load(&format!(
        r#"<scene><backColor>0.2 0.4 0.8</backColor>{CAM_2015}
        <surface type="Sphere"><shader type="Glass"><refractiveIndex>1.5</refractiveIndex></shader></surface>
        <surface type="Box"><minPt>-5 -5 -5</minPt><maxPt>5 5 -4</maxPt></surface>
        <light type="PointLight"><position>0 3 3</position><intensity>20 20 20</intensity></light></scene>"#
    ));
    let f = film(&s);
    for y in 0..21 {
        for x in 0..21 {
            assert!(f.get(x, y).is_finite(), "({x},{y})");
        }
    }
}

#[test]
fn deep_nesting_is_a_clean_error_not_a_stack_overflow() {
    let depth = 20_000;
    let mut xml = String::from("<scene><camera/><image>2 2</image>");
    for _ in 0..depth {
        xml.push_str(r#"<surface type="Group">"#);
    }
    xml.push_str(r#"<surface type="Sphere"/>"#);
    for _ in 0..depth {
        xml.push_str("</surface>");
    }
    xml.push_str("</scene>");
    let err = parse_scene(&xml, Path::new("deep.xml"))
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("deep.xml:1:"), "{err}");
    assert!(err.contains("nested"), "{err}");
}

#[test]
fn non_finite_vertices_are_dropped_not_traced() {
    use arbor::load::MeshData;
    use arbor::surface::{MeshSurface, Surface};
    use glam::Vec3;
    let mut scene = load("<scene><camera/><image>2 2</image></scene>");
    let data = MeshData {
        positions: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::new(0.5, 0.5, 0.0),
        ],
        normals: None,
        uvs: None,
        colors: None,
        // A good triangle, one with a NaN corner, and a zero-area one (kept,
        // but never hit: Cramer's determinant is zero).
        triangles: vec![[0, 1, 2], [0, 3, 2], [0, 4, 4]],
    };
    scene.surfaces.push(Surface::Mesh(MeshSurface {
        data: std::sync::Arc::new(data),
        shader: std::sync::Arc::new(arbor::shader::Shader::default_lambertian()),
        two_sided: false,
        soft_terminator: false,
    }));
    let flat = FlatGeometry::new(&scene).unwrap();
    assert_eq!((flat.len(), flat.dropped()), (2, 1));
    let tracer = Tracer::build(FlattenedScene::from_world(flat), &TracerOptions::default());
    let hit = tracer.closest(&Ray::new(
        DVec3::new(0.25, 0.25, 1.0),
        DVec3::NEG_Z,
        0.0,
        f64::INFINITY,
    ));
    assert!((hit.unwrap().t - 1.0).abs() < 1e-12);
    assert!(tracer
        .closest(&Ray::new(
            DVec3::new(2.0, 2.0, 1.0),
            DVec3::NEG_Z,
            0.0,
            f64::INFINITY
        ))
        .is_none());
}

/// Imported models are shaded from both sides: a ray meeting a triangle
/// from behind gets the normal turned towards it, unless the surface is
/// one-sided (the course's scenes) or glass (refraction needs the outward
/// normal). The side comes from the winding, so vertex normals that
/// disagree with it are left alone when they already face the ray.
#[test]
fn two_sided_meshes_turn_the_normal_to_the_ray() {
    use arbor::load::MeshData;
    use arbor::shader::Shader;
    use arbor::surface::{MeshSurface, Surface};
    use glam::Vec3;
    use std::sync::Arc;
    // Counter-clockwise seen from +z: the winding's normal is +z.
    let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
    let normal_of = |two_sided: bool, shader: Shader, normals: Option<Vec3>, from_z: f64| {
        let mut scene = load("<scene><camera/><image>2 2</image></scene>");
        scene.surfaces.push(Surface::Mesh(MeshSurface {
            data: Arc::new(MeshData {
                positions: positions.clone(),
                normals: normals.map(|n| vec![n; 3]),
                uvs: None,
                colors: None,
                triangles: vec![[0, 1, 2]],
            }),
            shader: Arc::new(shader),
            two_sided,
            soft_terminator: false,
        }));
        let tracer = Tracer::build(
            FlattenedScene::from_world(FlatGeometry::new(&scene).unwrap()),
            &TracerOptions::default(),
        );
        let o = DVec3::new(0.25, 0.25, from_z);
        let d = DVec3::new(0.0, 0.0, -from_z.signum());
        tracer
            .closest(&Ray::new(o, d, 0.0, f64::INFINITY))
            .unwrap()
            .normal
    };
    let lambert = Shader::default_lambertian;
    let glass = || Shader::Glass {
        refractive_index: 1.5,
    };
    // From the front: the winding's normal for everyone.
    assert_eq!(normal_of(true, lambert(), None, 1.0), DVec3::Z);
    assert_eq!(normal_of(false, lambert(), None, 1.0), DVec3::Z);
    // From behind: turned only when two-sided and not glass.
    assert_eq!(normal_of(true, lambert(), None, -1.0), DVec3::NEG_Z);
    assert_eq!(normal_of(false, lambert(), None, -1.0), DVec3::Z);
    assert_eq!(normal_of(true, glass(), None, -1.0), DVec3::Z);
    // Vertex normals: turned when on the far side of the triangle, kept
    // when they already face the ray.
    assert_eq!(
        normal_of(true, lambert(), Some(Vec3::Z), -1.0),
        DVec3::NEG_Z
    );
    assert_eq!(
        normal_of(true, lambert(), Some(Vec3::NEG_Z), -1.0),
        DVec3::NEG_Z
    );
    assert_eq!(normal_of(true, lambert(), Some(Vec3::NEG_Z), 1.0), DVec3::Z);
}

/// Every model importer marks its meshes two-sided.
#[test]
fn imported_models_are_two_sided() {
    use arbor::surface::Surface;
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("quad.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    let stl = dir.path().join("tri.stl");
    std::fs::write(
        &stl,
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
         vertex 0 1 0\nendloop\nendfacet\nendsolid t\n",
    )
    .unwrap();
    for path in [obj, stl] {
        let model = arbor::load::load_model(&path).unwrap();
        assert!(!model.surfaces.is_empty());
        for s in &model.surfaces {
            match s {
                Surface::Mesh(m) => assert!(m.two_sided, "{}", path.display()),
                other => panic!("expected a mesh, got {other:?}"),
            }
        }
    }
}

#[test]
fn texture_replaces_the_diffuse_colour() {
    // A 2x1 texture, red on the left (u < 0.5), blue on the right.
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("tex.png");
    image::RgbImage::from_fn(2, 1, |x, _| {
        if x == 0 {
            image::Rgb([255, 0, 0])
        } else {
            image::Rgb([0, 0, 255])
        }
    })
    .save(&png)
    .unwrap();
    let xml = format!(
        r#"<scene>{CAM_2015}<surface type="Sphere"><shader type="Lambertian"><texture type="ClampTexture"><image>tex.png</image></texture></shader></surface>
        <light type="DirectionalLight"><direction>0 0 1</direction></light></scene>"#
    );
    let scene = parse_scene(&xml, &dir.path().join("s.xml")).unwrap().scene;
    let f = film(&scene);
    // The sphere's u = (atan2(nx, nz) + pi) / 2pi is 0.5 facing the camera,
    // so the lookup x = floor(0.5 * 2 + 0.5) = 1: the blue texel, lit by
    // the light behind the camera; no red at all.
    let centre = f.get(10, 10);
    assert!(centre.z > 0.5 && centre.x == 0.0, "{centre:?}");
    let missing = format!(
        r#"<scene>{CAM_2015}<shader type="Lambertian"><texture type="ClampTexture"><image>none.png</image></texture></shader></scene>"#
    );
    let err = parse_scene(&missing, &dir.path().join("s.xml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("cannot read texture image"), "{err}");
}
