//! The interface a compute shader's SPIR-V declares: its descriptor bindings (set, binding, kind,
//! GLSL name) and the size of its push-constant block. Read when a pipeline is created, so a
//! pass's Rust-side declaration is checked against what the shader really expects (a mismatch is
//! an error naming the shader and the binding), not trusted.
//!
//! A small reader of the SPIR-V binary (Khronos SPIR-V specification 1.6, sec. 2.3 "Physical
//! Layout", sec. 3 "Binary Form" for the opcode, decoration and storage-class numbers): only the
//! instructions that describe types, names, decorations and variables are looked at.

use std::collections::HashMap;

/// What a descriptor binding holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    /// `image2D` used with imageLoad/imageStore (layout GENERAL).
    StorageImage,
    /// A `buffer` block (std430).
    StorageBuffer,
    /// A `uniform` block.
    UniformBuffer,
}

impl BindingKind {
    pub fn descriptor_type(self) -> ash::vk::DescriptorType {
        match self {
            BindingKind::StorageImage => ash::vk::DescriptorType::STORAGE_IMAGE,
            BindingKind::StorageBuffer => ash::vk::DescriptorType::STORAGE_BUFFER,
            BindingKind::UniformBuffer => ash::vk::DescriptorType::UNIFORM_BUFFER,
        }
    }
}

impl std::fmt::Display for BindingKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            BindingKind::StorageImage => "a storage image",
            BindingKind::StorageBuffer => "a storage buffer",
            BindingKind::UniformBuffer => "a uniform buffer",
        })
    }
}

/// One descriptor binding of the shader.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReflectedBinding {
    pub set: u32,
    pub binding: u32,
    pub kind: BindingKind,
    /// The variable's name for images; the block's name for buffers (whose instance is usually
    /// anonymous in GLSL).
    pub name: String,
}

/// The shader's resource interface.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ShaderInterface {
    /// Sorted by (set, binding).
    pub bindings: Vec<ReflectedBinding>,
    /// Bytes the push-constant block spans (0 without one).
    pub push_constant_bytes: u32,
}

const MAGIC: u32 = 0x0723_0203;
// Opcodes (spec sec. 3.52).
const OP_NAME: u16 = 5;
const OP_TYPE_INT: u16 = 21;
const OP_TYPE_FLOAT: u16 = 22;
const OP_TYPE_VECTOR: u16 = 23;
const OP_TYPE_MATRIX: u16 = 24;
const OP_TYPE_IMAGE: u16 = 25;
const OP_TYPE_ARRAY: u16 = 28;
const OP_TYPE_STRUCT: u16 = 30;
const OP_TYPE_POINTER: u16 = 32;
const OP_CONSTANT: u16 = 43;
const OP_VARIABLE: u16 = 59;
const OP_DECORATE: u16 = 71;
const OP_MEMBER_DECORATE: u16 = 72;
// Decorations (sec. 3.20).
const DECORATION_BLOCK: u32 = 2;
const DECORATION_BUFFER_BLOCK: u32 = 3;
const DECORATION_ARRAY_STRIDE: u32 = 6;
const DECORATION_MATRIX_STRIDE: u32 = 7;
const DECORATION_BINDING: u32 = 33;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
const DECORATION_OFFSET: u32 = 35;
// Storage classes (sec. 3.7).
const STORAGE_UNIFORM_CONSTANT: u32 = 0;
const STORAGE_UNIFORM: u32 = 2;
const STORAGE_PUSH_CONSTANT: u32 = 9;
const STORAGE_STORAGE_BUFFER: u32 = 12;

#[derive(Clone, Debug)]
enum Type {
    Scalar {
        bytes: u32,
    },
    Vector {
        component: u32,
        count: u32,
    },
    Matrix {
        column: u32,
        count: u32,
    },
    /// `sampled` = 2: a storage image.
    Image {
        sampled: u32,
    },
    Array {
        element: u32,
        length_id: u32,
    },
    Struct {
        members: Vec<u32>,
    },
    Pointer {
        pointee: u32,
    },
    Other,
}

#[derive(Default)]
struct Module {
    names: HashMap<u32, String>,
    types: HashMap<u32, Type>,
    constants: HashMap<u32, u32>,
    decorations: HashMap<(u32, u32), u32>,
    flags: HashMap<u32, Vec<u32>>,
    member_offsets: HashMap<(u32, u32), u32>,
    array_strides: HashMap<u32, u32>,
    matrix_strides: HashMap<(u32, u32), u32>,
    variables: Vec<(u32, u32, u32)>,
}

/// Read the interface of a SPIR-V module (little-endian words, as shaderc writes them).
pub fn interface(spirv: &[u8]) -> Result<ShaderInterface, String> {
    if !spirv.len().is_multiple_of(4) || spirv.len() < 20 {
        return Err(format!("{} bytes is not a SPIR-V module", spirv.len()));
    }
    let words: Vec<u32> = spirv.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    if words[0] != MAGIC {
        return Err(format!("bad SPIR-V magic number {:#010x}", words[0]));
    }
    let module = Module::read(&words[5..])?;
    module.interface()
}

impl Module {
    fn read(mut code: &[u32]) -> Result<Module, String> {
        let mut m = Module::default();
        while let Some(&first) = code.first() {
            let (count, opcode) = ((first >> 16) as usize, (first & 0xffff) as u16);
            if count == 0 || count > code.len() {
                return Err(format!("truncated instruction (opcode {opcode})"));
            }
            let ops = &code[1..count];
            let word = |i: usize| ops.get(i).copied().ok_or_else(|| format!("short instruction (opcode {opcode})"));
            match opcode {
                OP_NAME => {
                    m.names.insert(word(0)?, literal_string(&ops[1..]));
                }
                OP_TYPE_INT | OP_TYPE_FLOAT => {
                    m.types.insert(word(0)?, Type::Scalar { bytes: word(1)? / 8 });
                }
                OP_TYPE_VECTOR => {
                    m.types.insert(word(0)?, Type::Vector { component: word(1)?, count: word(2)? });
                }
                OP_TYPE_MATRIX => {
                    m.types.insert(word(0)?, Type::Matrix { column: word(1)?, count: word(2)? });
                }
                OP_TYPE_IMAGE => {
                    m.types.insert(word(0)?, Type::Image { sampled: word(6)? });
                }
                OP_TYPE_ARRAY => {
                    m.types.insert(word(0)?, Type::Array { element: word(1)?, length_id: word(2)? });
                }
                OP_TYPE_STRUCT => {
                    m.types.insert(word(0)?, Type::Struct { members: ops[1..].to_vec() });
                }
                OP_TYPE_POINTER => {
                    m.types.insert(word(0)?, Type::Pointer { pointee: word(2)? });
                }
                OP_CONSTANT => {
                    m.constants.insert(word(1)?, word(2)?);
                }
                OP_VARIABLE => m.variables.push((word(0)?, word(1)?, word(2)?)),
                OP_DECORATE => {
                    let (target, decoration) = (word(0)?, word(1)?);
                    match decoration {
                        DECORATION_BINDING | DECORATION_DESCRIPTOR_SET => {
                            m.decorations.insert((target, decoration), word(2)?);
                        }
                        DECORATION_ARRAY_STRIDE => {
                            m.array_strides.insert(target, word(2)?);
                        }
                        _ => m.flags.entry(target).or_default().push(decoration),
                    }
                }
                OP_MEMBER_DECORATE => {
                    let (target, member, decoration) = (word(0)?, word(1)?, word(2)?);
                    match decoration {
                        DECORATION_OFFSET => {
                            m.member_offsets.insert((target, member), word(3)?);
                        }
                        DECORATION_MATRIX_STRIDE => {
                            m.matrix_strides.insert((target, member), word(3)?);
                        }
                        _ => {}
                    }
                }
                // Any other type declaration: remember its id so sizes fail loudly, not wrongly.
                19..=39 => {
                    if let Some(&id) = ops.first() {
                        m.types.entry(id).or_insert(Type::Other);
                    }
                }
                _ => {}
            }
            code = &code[count..];
        }
        Ok(m)
    }

    fn interface(&self) -> Result<ShaderInterface, String> {
        let mut out = ShaderInterface::default();
        for &(pointer_type, id, storage) in &self.variables {
            let pointee = match self.types.get(&pointer_type) {
                Some(Type::Pointer { pointee, .. }) => *pointee,
                _ => continue,
            };
            if storage == STORAGE_PUSH_CONSTANT {
                out.push_constant_bytes = self.size_of(pointee)?;
                continue;
            }
            let kind = match (storage, self.types.get(&pointee)) {
                (STORAGE_UNIFORM_CONSTANT, Some(Type::Image { sampled: 2 })) => BindingKind::StorageImage,
                (STORAGE_STORAGE_BUFFER, _) => BindingKind::StorageBuffer,
                (STORAGE_UNIFORM, _) if self.has_flag(pointee, DECORATION_BUFFER_BLOCK) => BindingKind::StorageBuffer,
                (STORAGE_UNIFORM, _) if self.has_flag(pointee, DECORATION_BLOCK) => BindingKind::UniformBuffer,
                _ => continue,
            };
            let (Some(&set), Some(&binding)) = (
                self.decorations.get(&(id, DECORATION_DESCRIPTOR_SET)),
                self.decorations.get(&(id, DECORATION_BINDING)),
            ) else {
                continue;
            };
            let name = match self.names.get(&id).filter(|n| !n.is_empty()) {
                Some(n) => n.clone(),
                None => self.names.get(&pointee).cloned().unwrap_or_default(),
            };
            out.bindings.push(ReflectedBinding { set, binding, kind, name });
        }
        out.bindings.sort_by_key(|b| (b.set, b.binding));
        Ok(out)
    }

    fn has_flag(&self, id: u32, decoration: u32) -> bool {
        self.flags.get(&id).is_some_and(|f| f.contains(&decoration))
    }

    /// Bytes a type spans in an explicitly laid-out block (offsets and strides as decorated).
    fn size_of(&self, id: u32) -> Result<u32, String> {
        match self.types.get(&id) {
            Some(Type::Scalar { bytes }) => Ok(*bytes),
            Some(Type::Vector { component, count }) => Ok(self.size_of(*component)? * count),
            Some(Type::Matrix { column, count }) => Ok(self.size_of(*column)? * count),
            Some(Type::Array { element, length_id }) => {
                let length = self.constants.get(length_id).copied().ok_or("an array of unknown length")?;
                let stride = match self.array_strides.get(&id) {
                    Some(&s) => s,
                    None => self.size_of(*element)?,
                };
                Ok(stride * length)
            }
            Some(Type::Struct { members }) => {
                let mut end = 0;
                for (i, &member) in members.iter().enumerate() {
                    let offset = self
                        .member_offsets
                        .get(&(id, i as u32))
                        .copied()
                        .ok_or_else(|| format!("member {i} of a block has no offset"))?;
                    let size = match (self.types.get(&member), self.matrix_strides.get(&(id, i as u32))) {
                        (Some(Type::Matrix { count, .. }), Some(stride)) => stride * count,
                        _ => self.size_of(member)?,
                    };
                    end = end.max(offset + size);
                }
                Ok(end)
            }
            _ => Err(format!("type %{id} has no size in a block")),
        }
    }
}

/// A SPIR-V literal string: UTF-8 bytes packed little-endian into words, NUL-terminated.
fn literal_string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).take_while(|&b| b != 0).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shader(name: &str) -> ShaderInterface {
        interface(crate::gpu::shaders::spirv(name).unwrap()).unwrap()
    }

    #[test]
    fn reads_the_bindings_and_push_constants_of_the_compiled_shaders() {
        // glsl/dof/coc_edges.comp: depth (image), coc_px (image), the field-curvature buffer, the
        // colour, the edge list's args and pixels; push block (glsl/include/coc.glsl) of 15
        // four-byte fields.
        let coc = shader("coc_edges");
        let names: Vec<(u32, BindingKind, &str)> =
            coc.bindings.iter().map(|b| (b.binding, b.kind, b.name.as_str())).collect();
        assert_eq!(
            names,
            [
                (0, BindingKind::StorageImage, "depth_m"),
                (1, BindingKind::StorageImage, "coc_px"),
                (2, BindingKind::StorageBuffer, "FieldCurvature"),
                (3, BindingKind::StorageImage, "color_in"),
                (4, BindingKind::StorageBuffer, "Args"),
                (5, BindingKind::StorageBuffer, "EdgePixels")
            ]
        );
        assert_eq!(coc.push_constant_bytes, 15 * 4);
        // glsl/dof/dof_composite.comp: a nested struct (Aperture, 12 fields) inside the push block,
        // and binding numbers declared out of order through an include.
        let composite = shader("dof_composite");
        assert_eq!(composite.push_constant_bytes, (2 + 2 + 2 + 1 + 1 + 12 + 1 + 1) * 4);
        let bindings: Vec<u32> = composite.bindings.iter().map(|b| b.binding).collect();
        assert_eq!(bindings, (0..12).collect::<Vec<_>>());
        assert_eq!(composite.bindings[6].name, "ApertureMask");
    }

    #[test]
    fn rejects_what_is_not_spir_v() {
        assert!(interface(&[0u8; 7]).unwrap_err().contains("not a SPIR-V module"));
        assert!(interface(&[1u8; 40]).unwrap_err().contains("magic"));
    }
}
