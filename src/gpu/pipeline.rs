//! A compute pipeline with its own descriptor-set layout and push-constant range. Each pass in
//! `src/passes/` creates one of these for its shader; nothing else is shared between passes.

use super::context::Shared;
use super::kernel::Binding;
use super::{Gpu, GpuError, GpuResult, VkContext};
use ash::vk;
use std::sync::Arc;

pub struct ComputePipeline {
    shared: Arc<Shared>,
    pub pipeline: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
    pub bindings: Vec<Binding>,
    pub push_constant_bytes: u32,
    pub name: &'static str,
}

impl ComputePipeline {
    /// `bindings[i]` is binding `i` of set 0; `constants[i]` is the shader's specialization
    /// constant `constant_id = i` (a 32-bit value: bool, int or uint; none: the shader's
    /// defaults). Passes create theirs through [`Kernel::new`](super::Kernel::new) or
    /// [`SpecializedKernel`](super::SpecializedKernel), which first check them against the SPIR-V.
    pub fn new(
        gpu: &Gpu,
        name: &'static str,
        spirv: &[u8],
        bindings: &[Binding],
        push_constant_bytes: u32,
        constants: &[u32],
    ) -> GpuResult<ComputePipeline> {
        let device = gpu.device();
        let code = ash::util::read_spv(&mut std::io::Cursor::new(spirv)).map_err(|_| GpuError::Spirv(name))?;
        let layout_bindings: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(i, b)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(b.kind.descriptor_type())
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        unsafe {
            let set_layout = device
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings),
                    None,
                )
                .vk("vkCreateDescriptorSetLayout")?;
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .offset(0)
                .size(push_constant_bytes)];
            let set_layouts = [set_layout];
            let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
            if push_constant_bytes > 0 {
                layout_info = layout_info.push_constant_ranges(&ranges);
            }
            let layout = device.create_pipeline_layout(&layout_info, None).vk("vkCreatePipelineLayout")?;
            let module = device
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&code), None)
                .vk("vkCreateShaderModule")?;
            let entries: Vec<vk::SpecializationMapEntry> = (0..constants.len() as u32)
                .map(|i| vk::SpecializationMapEntry::default().constant_id(i).offset(4 * i).size(4))
                .collect();
            let specialization =
                vk::SpecializationInfo::default().map_entries(&entries).data(bytemuck::cast_slice(constants));
            let mut stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            if !constants.is_empty() {
                stage = stage.specialization_info(&specialization);
            }
            let info = vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout);
            let started = std::time::Instant::now();
            let created = device.create_compute_pipelines(gpu.shared.pipeline_cache, &[info], None);
            device.destroy_shader_module(module, None);
            let pipeline = match created {
                Ok(p) => p[0],
                Err((_, result)) => {
                    device.destroy_pipeline_layout(layout, None);
                    device.destroy_descriptor_set_layout(set_layout, None);
                    return Err(GpuError::Vk { call: "vkCreateComputePipelines", result });
                }
            };
            log::debug!("pipeline {name} created in {:.1} ms", started.elapsed().as_secs_f64() * 1e3);
            gpu.shared.pipelines_created.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            gpu.set_name(pipeline, name);
            gpu.set_name(layout, name);
            gpu.set_name(set_layout, name);
            Ok(ComputePipeline {
                shared: gpu.shared.clone(),
                pipeline,
                layout,
                set_layout,
                bindings: bindings.to_vec(),
                push_constant_bytes,
                name,
            })
        }
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        unsafe {
            self.shared.device.destroy_pipeline(self.pipeline, None);
            self.shared.device.destroy_pipeline_layout(self.layout, None);
            self.shared.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
