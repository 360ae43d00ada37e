//! `rigid export`: the run as a binary glTF 2.0 file (.glb) — one mesh per distinct shape, one
//! node per actor, and an animation with translation and rotation channels sampled every K
//! steps (and at the last step), so the run plays in Blender or any glTF viewer. glTF is +y
//! up, right-handed, metres, quaternions (x, y, z, w): the sandbox's own conventions.

use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use std::collections::BTreeMap;

/// Poses of every actor at one sampled time.
#[derive(Clone, Debug, PartialEq)]
pub struct Keyframe {
    /// Simulated time [s].
    pub time: f64,
    /// Per actor (index order): position and orientation (x, y, z, w).
    pub poses: Vec<([f64; 3], [f64; 4])>,
}

/// What the exporter needs of the scene: per actor its name, mesh index and whether it moves;
/// per mesh its triangles as world-independent vertex lists.
pub struct ExportScene<'a> {
    /// (name, mesh index into `meshes`, fixed, colour).
    pub actors: Vec<(String, usize, bool, [u8; 3])>,
    /// Distinct meshes.
    pub meshes: Vec<&'a crate::model::mesh::ConvexMesh>,
}

/// Appends little-endian f32s to the blob and returns a view + accessor for them.
struct Blob {
    bytes: Vec<u8>,
}

impl Blob {
    fn push_f32(
        &mut self,
        root: &mut json::Root,
        values: &[f32],
        kind: json::accessor::Type,
        with_bounds: bool,
    ) -> json::Index<json::Accessor> {
        let offset = self.bytes.len();
        for v in values {
            self.bytes.extend_from_slice(&v.to_le_bytes());
        }
        let width = match kind {
            json::accessor::Type::Scalar => 1,
            json::accessor::Type::Vec3 => 3,
            _ => 4,
        };
        let view = root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(values.len() * 4),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: None,
            extensions: None,
            extras: Default::default(),
        });
        let (min, max) = if with_bounds {
            let mut lo = vec![f32::INFINITY; width];
            let mut hi = vec![f32::NEG_INFINITY; width];
            for chunk in values.chunks(width) {
                for (k, &v) in chunk.iter().enumerate() {
                    lo[k] = lo[k].min(v);
                    hi[k] = hi[k].max(v);
                }
            }
            (Some(json::Value::from(lo)), Some(json::Value::from(hi)))
        } else {
            (None, None)
        };
        root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(values.len() / width),
            component_type: Valid(json::accessor::GenericComponentType(json::accessor::ComponentType::F32)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(kind),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }
}

/// Builds the .glb bytes: meshes (flat-shaded triangles with face normals), one material per
/// mesh, one node per actor at its first pose, and one animation over `frames`.
#[must_use]
pub fn glb(scene: &ExportScene, frames: &[Keyframe]) -> Vec<u8> {
    let mut root = json::Root {
        asset: json::Asset { generator: Some("rigid-sandbox".into()), version: "2.0".into(), ..Default::default() },
        ..Default::default()
    };
    let mut blob = Blob { bytes: Vec::new() };
    let mut mesh_index = Vec::new();
    for (k, mesh) in scene.meshes.iter().enumerate() {
        let (mut positions, mut normals) = (Vec::new(), Vec::new());
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            for p in [a, b, c] {
                positions.extend(p.to_array().map(|x| x as f32));
                normals.extend(n.to_array().map(|x| x as f32));
            }
        }
        let pos = blob.push_f32(&mut root, &positions, json::accessor::Type::Vec3, true);
        let nor = blob.push_f32(&mut root, &normals, json::accessor::Type::Vec3, false);
        let colour = scene.actors.iter().find(|a| a.1 == k).map_or([200, 200, 200], |a| a.3);
        let material = root.push(json::Material {
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor([
                    f32::from(colour[0]) / 255.0,
                    f32::from(colour[1]) / 255.0,
                    f32::from(colour[2]) / 255.0,
                    1.0,
                ]),
                metallic_factor: json::material::StrengthFactor(0.0),
                ..Default::default()
            },
            ..Default::default()
        });
        let attributes = BTreeMap::from([
            (Valid(json::mesh::Semantic::Positions), pos),
            (Valid(json::mesh::Semantic::Normals), nor),
        ]);
        mesh_index.push(root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: Some(format!("mesh-{k}")),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: Default::default(),
                indices: None,
                material: Some(material),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            }],
            weights: None,
        }));
    }
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
    let nodes: Vec<json::Index<json::Node>> = scene
        .actors
        .iter()
        .enumerate()
        .map(|(i, (name, mesh, _, _))| {
            let (p, q) = frames.first().map_or(([0.0; 3], [0.0, 0.0, 0.0, 1.0]), |f| f.poses[i]);
            root.push(json::Node {
                mesh: Some(mesh_index[*mesh]),
                name: Some(name.clone()),
                translation: Some([p[0] as f32, p[1] as f32, p[2] as f32]),
                rotation: Some(json::scene::UnitQuaternion([q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32])),
                ..Default::default()
            })
        })
        .collect();
    root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: Some("rigid".into()),
        nodes: nodes.clone(),
    });
    root.scene = Some(json::Index::new(0));
    if frames.len() > 1 {
        let times: Vec<f64> = frames.iter().map(|f| f.time).collect();
        let input = blob.push_f32(&mut root, &f32s(&times), json::accessor::Type::Scalar, true);
        let (mut channels, mut samplers) = (Vec::new(), Vec::new());
        for (i, node) in nodes.iter().enumerate().filter(|(i, _)| !scene.actors[*i].2) {
            let translation: Vec<f64> = frames.iter().flat_map(|f| f.poses[i].0).collect();
            let rotation: Vec<f64> = frames.iter().flat_map(|f| f.poses[i].1).collect();
            for (values, kind, path) in [
                (translation, json::accessor::Type::Vec3, json::animation::Property::Translation),
                (rotation, json::accessor::Type::Vec4, json::animation::Property::Rotation),
            ] {
                let output = blob.push_f32(&mut root, &f32s(&values), kind, false);
                let sampler = json::Index::new(samplers.len() as u32);
                samplers.push(json::animation::Sampler {
                    extensions: None,
                    extras: Default::default(),
                    input,
                    interpolation: Valid(json::animation::Interpolation::Linear),
                    output,
                });
                channels.push(json::animation::Channel {
                    sampler,
                    target: json::animation::Target {
                        extensions: None,
                        extras: Default::default(),
                        node: *node,
                        path: Valid(path),
                    },
                    extensions: None,
                    extras: Default::default(),
                });
            }
        }
        root.push(json::Animation {
            extensions: None,
            extras: Default::default(),
            channels,
            name: Some("run".into()),
            samplers,
        });
    }
    while !blob.bytes.len().is_multiple_of(4) {
        blob.bytes.push(0);
    }
    root.push(json::Buffer {
        byte_length: USize64::from(blob.bytes.len()),
        name: None,
        uri: None,
        extensions: None,
        extras: Default::default(),
    });
    container(&json::serialize::to_string(&root).expect("plain data serialises"), &blob.bytes)
}

/// The GLB container: 12-byte header, a JSON chunk padded with spaces and a BIN chunk padded
/// with zeros, each to 4 bytes (glTF 2.0 §4.4).
fn container(json_text: &str, bin: &[u8]) -> Vec<u8> {
    let mut json_bytes = json_text.as_bytes().to_vec();
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}
