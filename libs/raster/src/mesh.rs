//! Triangle meshes as the renderer draws them, and their levels of detail.
//!
//! A [`Mesh`] has per-corner normals (MuJoCo's `mesh_facenormal`: a vertex on a sharp edge has
//! one normal per face). [`MeshLods`] keeps the full mesh and coarser versions simplified once
//! by meshoptimizer, whose corners take the area-weighted vertex normals of the full mesh; a
//! body is drawn at the finest level with no more triangles than pixels in its projected disc
//! ([`MeshLods::level_for`]), and at the full level whenever it is large in the image.

/// Why a mesh was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    #[error("mesh {name}: no triangles")]
    Empty { name: String },
    #[error("mesh {name}: triangle {triangle} names vertex {vertex} of {vertices}")]
    BadIndex {
        name: String,
        triangle: usize,
        vertex: u32,
        vertices: usize,
    },
    #[error("mesh {name}: {what} {index} is not finite")]
    NotFinite {
        name: String,
        what: &'static str,
        index: usize,
    },
    #[error("mesh {name}: {normals} corner normals for {triangles} triangles")]
    NormalCount {
        name: String,
        normals: usize,
        triangles: usize,
    },
}

/// A triangle mesh in its own frame, counter-clockwise front faces.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    positions_m: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    normals: Vec<[[f32; 3]; 3]>,
    /// The distinct corner normals (first-use order) and each corner's index into them: a
    /// render lights each distinct normal once.
    distinct_normals: Vec<[f32; 3]>,
    corner_normal: Vec<[u32; 3]>,
}

impl Mesh {
    /// Checks and builds a mesh; `name` is what errors call it (its file, say).
    pub fn new(
        name: &str,
        positions_m: Vec<[f32; 3]>,
        triangles: Vec<[u32; 3]>,
        normals: Vec<[[f32; 3]; 3]>,
    ) -> Result<Mesh, MeshError> {
        let name = || name.to_owned();
        if triangles.is_empty() {
            return Err(MeshError::Empty { name: name() });
        }
        if normals.len() != triangles.len() {
            return Err(MeshError::NormalCount {
                name: name(),
                normals: normals.len(),
                triangles: triangles.len(),
            });
        }
        if let Some(index) = positions_m
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(MeshError::NotFinite {
                name: name(),
                what: "vertex",
                index,
            });
        }
        if let Some(index) = normals
            .iter()
            .position(|t| t.iter().flatten().any(|c| !c.is_finite()))
        {
            return Err(MeshError::NotFinite {
                name: name(),
                what: "normal of triangle",
                index,
            });
        }
        for (triangle, t) in triangles.iter().enumerate() {
            if let Some(&vertex) = t.iter().find(|&&v| v as usize >= positions_m.len()) {
                return Err(MeshError::BadIndex {
                    name: name(),
                    triangle,
                    vertex,
                    vertices: positions_m.len(),
                });
            }
        }
        Ok(Mesh::assemble(positions_m, triangles, normals))
    }

    fn assemble(
        positions_m: Vec<[f32; 3]>,
        triangles: Vec<[u32; 3]>,
        normals: Vec<[[f32; 3]; 3]>,
    ) -> Mesh {
        let mut index: std::collections::BTreeMap<[u32; 3], u32> = Default::default();
        let mut distinct_normals = Vec::new();
        let corner_normal = normals
            .iter()
            .map(|corners| {
                corners.map(|n| {
                    *index.entry(n.map(f32::to_bits)).or_insert_with(|| {
                        distinct_normals.push(n);
                        (distinct_normals.len() - 1) as u32
                    })
                })
            })
            .collect();
        Mesh {
            positions_m,
            triangles,
            normals,
            distinct_normals,
            corner_normal,
        }
    }

    /// The distinct corner normals.
    pub fn distinct_normals(&self) -> &[[f32; 3]] {
        &self.distinct_normals
    }

    /// Each triangle's corners as indices into [`Mesh::distinct_normals`].
    pub fn corner_normal(&self) -> &[[u32; 3]] {
        &self.corner_normal
    }

    pub fn positions_m(&self) -> &[[f32; 3]] {
        &self.positions_m
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// One normal per corner of each triangle.
    pub fn normals(&self) -> &[[[f32; 3]; 3]] {
        &self.normals
    }

    /// The radius about the mesh origin that holds every vertex, m.
    pub fn radius_m(&self) -> f64 {
        self.positions_m
            .iter()
            .map(|p| {
                let [x, y, z] = p.map(f64::from);
                (x * x + y * y + z * z).sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// Each vertex's distinct corner normals (a vertex on a sharp edge has one per side).
    fn corner_normals_by_vertex(&self) -> Vec<Vec<[f32; 3]>> {
        let mut by_vertex = vec![Vec::new(); self.positions_m.len()];
        for (t, corners) in self.triangles.iter().zip(&self.normals) {
            for (k, &v) in t.iter().enumerate() {
                let list: &mut Vec<[f32; 3]> = &mut by_vertex[v as usize];
                if !list.contains(&corners[k]) {
                    list.push(corners[k]);
                }
            }
        }
        by_vertex
    }
}

/// A level of `next`'s triangles over only the vertices they use (in first-use order). Each
/// corner takes, of the full mesh's normals at that vertex, the one nearest the simplified
/// face's own normal: flat sides stay flat and sharp edges sharp, as MuJoCo shades them.
fn compact(positions_m: &[[f32; 3]], normals: &[Vec<[f32; 3]>], next: &[u32]) -> Mesh {
    let mut new_index = vec![u32::MAX; positions_m.len()];
    let mut kept = Vec::new();
    let triangles: Vec<[u32; 3]> = next
        .chunks_exact(3)
        .map(|t| {
            [t[0], t[1], t[2]].map(|v| {
                let slot = &mut new_index[v as usize];
                if *slot == u32::MAX {
                    *slot = kept.len() as u32;
                    kept.push(v);
                }
                *slot
            })
        })
        .collect();
    let corner_normals = next
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|v| positions_m[v as usize].map(f64::from));
            let face = cross(
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            [t[0], t[1], t[2]].map(|v| {
                let mut best = [0.0f32; 3];
                let mut best_dot = f64::NEG_INFINITY;
                for n in &normals[v as usize] {
                    let d = face[0] * f64::from(n[0])
                        + face[1] * f64::from(n[1])
                        + face[2] * f64::from(n[2]);
                    if d > best_dot {
                        best_dot = d;
                        best = *n;
                    }
                }
                // As MuJoCo shades: a corner normal far from its face gives way to the face's.
                let len = (face[0] * face[0] + face[1] * face[1] + face[2] * face[2]).sqrt();
                if len > 0.0 && best_dot / len < SHARP_COS {
                    face.map(|c| (c / len) as f32)
                } else {
                    best
                }
            })
        })
        .collect();
    Mesh::assemble(
        kept.iter().map(|&v| positions_m[v as usize]).collect(),
        triangles,
        corner_normals,
    )
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A corner normal whose cosine with its face's normal is below this is replaced by the face's
/// (MuJoCo's renderer does the same to the full mesh).
pub const SHARP_COS: f64 = 0.8;

/// Each simplified level aims at this fraction of the previous one's triangles.
const LEVEL_RATIO: usize = 3;
/// No level is made below this many triangles.
const MIN_LEVEL_TRIANGLES: usize = 48;
/// meshoptimizer's error bound, relative to the mesh's extent: a level stops short of its
/// triangle count rather than move the silhouette by more than this.
const SIMPLIFY_ERROR: f32 = 0.01;

/// Pixels of a body's bounding disc per triangle of the level drawn ([`MeshLods::level_for`]).
pub const PX_PER_TRIANGLE: f64 = 4.0;

/// A mesh at several levels of detail, finest first.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshLods {
    levels: Vec<Mesh>,
    radius_m: f64,
}

impl MeshLods {
    /// The full mesh and its simplified levels (each ≈ 1/3 of the one before, while that
    /// shrinks it by at least a tenth and leaves at least 48 triangles).
    pub fn build(full: Mesh) -> MeshLods {
        let radius_m = full.radius_m();
        let normals = full.corner_normals_by_vertex();
        let flat: Vec<f32> = full.positions_m.iter().flatten().copied().collect();
        let bytes: Vec<u8> = flat.iter().flat_map(|v| v.to_le_bytes()).collect();
        let indices: Vec<u32> = full.triangles.iter().flatten().copied().collect();
        let mut levels = vec![full];
        let Ok(adapter) = meshopt::VertexDataAdapter::new(&bytes, 12, 0) else {
            return MeshLods { levels, radius_m };
        };
        let mut current = indices;
        loop {
            let have = current.len() / 3;
            let want = have / LEVEL_RATIO;
            if want < MIN_LEVEL_TRIANGLES {
                break;
            }
            let next = meshopt::simplify(
                &current,
                &adapter,
                want * 3,
                SIMPLIFY_ERROR,
                meshopt::SimplifyOptions::None,
                None,
            );
            let got = next.len() / 3;
            if got == 0 || got * 10 > have * 9 {
                break;
            }
            levels.push(compact(&levels[0].positions_m, &normals, &next));
            current = next;
        }
        MeshLods { levels, radius_m }
    }

    /// The levels, finest (the full mesh) first.
    pub fn levels(&self) -> &[Mesh] {
        &self.levels
    }

    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    /// The level to draw for a body whose bounding sphere appears `radius_px` wide: the
    /// coarsest level with at least one triangle per [`PX_PER_TRIANGLE`] pixels of that disc.
    /// A body covers a fraction of its bounding disc and shows about half its triangles, so
    /// this keeps about one visible triangle per covered pixel or finer.
    pub fn level_for(&self, radius_px: f64) -> usize {
        let disc_px = std::f64::consts::PI * radius_px * radius_px;
        let mut chosen = 0;
        for (k, level) in self.levels.iter().enumerate() {
            if level.triangles.len() as f64 * PX_PER_TRIANGLE >= disc_px {
                chosen = k;
            }
        }
        chosen
    }

    /// FNV-1a over every level's bytes: what the level meshes are, for cache keys.
    pub fn digest(lods: &[MeshLods]) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for m in lods {
            for level in &m.levels {
                eat(&(level.triangles.len() as u64).to_le_bytes());
                for t in &level.triangles {
                    for v in t {
                        eat(&v.to_le_bytes());
                    }
                }
                for n in level.normals.iter().flatten().flatten() {
                    eat(&n.to_bits().to_le_bytes());
                }
                for p in level.positions_m.iter().flatten() {
                    eat(&p.to_bits().to_le_bytes());
                }
            }
        }
        h
    }
}
