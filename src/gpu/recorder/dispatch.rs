//! Dispatches: the bindings checked against the shader, a fresh descriptor set, and with twin
//! checks the bound resources read back around the dispatch and the CPU twin run on them.

use super::*;

impl Recorder {
    /// Bind `pipeline` with a fresh descriptor set holding `binds`, push the constants, dispatch.
    /// Reached through [`Kernel::dispatch`](crate::gpu::Kernel::dispatch), which knows the twin.
    pub(crate) fn dispatch(
        &mut self,
        pipeline: &ComputePipeline,
        binds: &[Bind<'_>],
        push_constants: &[u8],
        groups: [u32; 3],
        twin: TwinFn,
    ) -> GpuResult<()> {
        self.record_dispatch(pipeline, binds, push_constants, Groups::Direct(groups.map(|g| g.max(1))), twin)
    }

    /// Like [`Recorder::dispatch`], with the group counts read from `args` at `offset_bytes`
    /// (written by an earlier pass).
    pub(crate) fn dispatch_indirect(
        &mut self,
        pipeline: &ComputePipeline,
        binds: &[Bind<'_>],
        push_constants: &[u8],
        args: &GpuBuffer,
        offset_bytes: u64,
        twin: TwinFn,
    ) -> GpuResult<()> {
        self.record_dispatch(pipeline, binds, push_constants, Groups::Indirect(args, offset_bytes), twin)
    }

    fn record_dispatch(
        &mut self,
        pipeline: &ComputePipeline,
        binds: &[Bind<'_>],
        push_constants: &[u8],
        groups: Groups<'_>,
        twin: TwinFn,
    ) -> GpuResult<()> {
        check_binds(pipeline.name, &pipeline.bindings, binds)?;
        let before = match self.twin_checks {
            Some(_) => Some(self.read_back(binds, groups)?),
            None => None,
        };
        self.bind(pipeline, binds, push_constants)?;
        let device = self.gpu.device();
        match groups {
            Groups::Direct(g) => unsafe { device.cmd_dispatch(self.cb, g[0], g[1], g[2]) },
            Groups::Indirect(args, offset) => unsafe { device.cmd_dispatch_indirect(self.cb, args.buffer, offset) },
        }
        if let Some((mut twin_data, counts)) = before {
            let (mut gpu_data, _) = self.read_back(binds, Groups::Direct(counts))?;
            (twin.run)(push_constants, counts, &mut twin_data);
            (twin.canonical)(push_constants, &mut twin_data);
            (twin.canonical)(push_constants, &mut gpu_data);
            let result = compare_with_twin(pipeline.name, &pipeline.bindings, &gpu_data, &twin_data, twin.tolerance);
            let pass = self.open_span.and_then(|i| self.spans.get(i)).cloned().unwrap_or_default();
            if let Some(checks) = self.twin_checks.as_mut() {
                checks.push(TwinCheck { pass, shader: pipeline.name, groups: counts, result });
            }
        }
        Ok(())
    }

    /// Twin checks: submit what is recorded so far, then copy every bound resource back to the
    /// host (images from layout GENERAL), with the workgroup counts of the dispatch.
    fn read_back(&mut self, binds: &[Bind<'_>], groups: Groups<'_>) -> GpuResult<(Vec<HostData>, [u32; 3])> {
        self.flush()?;
        let mut staged = Vec::new();
        let device = self.gpu.device().clone();
        let copy_buffer = |rec: &mut Recorder, source: vk::Buffer, offset: u64, size: u64| -> GpuResult<GpuBuffer> {
            let staging = rec.gpu.create_buffer(
                "twin check read-back",
                size,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?;
            let region = vk::BufferCopy { src_offset: offset, dst_offset: 0, size };
            unsafe { device.cmd_copy_buffer(rec.cb, source, staging.buffer, &[region]) };
            Ok(staging)
        };
        // Every bound image is in GENERAL (the passes' own barriers put it there): to the copy's
        // layout for the read-back, and back. The flush's global barrier already ordered the
        // copies after everything recorded before.
        let layout = |image: &GpuImage, from: vk::ImageLayout, to: vk::ImageLayout| {
            vk::ImageMemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)
                .old_layout(from)
                .new_layout(to)
                .image(image.image)
                .subresource_range(color_range())
        };
        let images: Vec<&GpuImage> =
            binds.iter().filter_map(|b| if let Bind::Image(i) = b { Some(*i) } else { None }).collect();
        let (general, transfer) = (vk::ImageLayout::GENERAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL);
        self.image_barriers(&images.iter().map(|i| layout(i, general, transfer)).collect::<Vec<_>>());
        for b in binds {
            staged.push(match b {
                Bind::Image(image) => {
                    let size = image.width as u64 * image.height as u64 * image.channels() as u64 * 4;
                    let staging = self.gpu.create_buffer(
                        "twin check read-back",
                        size,
                        vk::BufferUsageFlags::TRANSFER_DST,
                        MemoryLocation::GpuToCpu,
                    )?;
                    let region = buffer_image_region(image);
                    unsafe {
                        device.cmd_copy_image_to_buffer(self.cb, image.image, transfer, staging.buffer, &[region])
                    };
                    staging
                }
                Bind::Buffer(buffer) => copy_buffer(self, buffer.buffer, 0, buffer.size_bytes)?,
            });
        }
        let args = match groups {
            Groups::Indirect(args, offset) => Some(copy_buffer(self, args.buffer, offset, 12)?),
            Groups::Direct(_) => None,
        };
        self.image_barriers(&images.iter().map(|i| layout(i, transfer, general)).collect::<Vec<_>>());
        // Copy writes -> host reads after the fence.
        self.memory_barrier(
            vk::MemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::COPY)
                .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::HOST)
                .dst_access_mask(vk::AccessFlags2::HOST_READ),
        );
        self.flush()?;
        let data = binds
            .iter()
            .zip(&staged)
            .map(|(b, staging)| match b {
                Bind::Image(image) => {
                    HostData::Image(HostImage::new(image.width, image.height, image.channels(), staging.read_f32()))
                }
                Bind::Buffer(_) => HostData::Buffer(staging.read_u32()),
            })
            .collect();
        let counts = match (groups, args) {
            (Groups::Direct(g), _) => g,
            (Groups::Indirect(..), Some(a)) => {
                let w = a.read_u32();
                [w[0], w[1], w[2]]
            }
            (Groups::Indirect(..), None) => [0; 3],
        };
        Ok((data, counts))
    }

    /// Twin checks: end and submit the command buffer, wait, and continue in a new one whose
    /// first barrier orders everything after everything before (memory writes made available
    /// and visible), so the split changes nothing for the passes.
    fn flush(&mut self) -> GpuResult<()> {
        let device = self.gpu.device().clone();
        unsafe {
            device.end_command_buffer(self.cb).vk("vkEndCommandBuffer")?;
            self.gpu.submit_and_wait(self.cb)?;
            self.cb = device
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(self.command_pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
                .vk("vkAllocateCommandBuffers")?[0];
            device
                .begin_command_buffer(
                    self.cb,
                    &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("vkBeginCommandBuffer")?;
        }
        self.memory_barrier(
            vk::MemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE),
        );
        Ok(())
    }

    fn bind(&mut self, pipeline: &ComputePipeline, binds: &[Bind<'_>], push_constants: &[u8]) -> GpuResult<()> {
        let device = self.gpu.device();
        unsafe {
            let layouts = [pipeline.set_layout];
            let set = device
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(self.descriptor_pool)
                        .set_layouts(&layouts),
                )
                .vk("vkAllocateDescriptorSets")?[0];
            for (i, b) in binds.iter().enumerate() {
                let write = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i as u32)
                    .descriptor_type(pipeline.bindings[i].kind.descriptor_type());
                match b {
                    Bind::Image(img) => {
                        let info = [vk::DescriptorImageInfo {
                            sampler: vk::Sampler::null(),
                            image_view: img.view,
                            image_layout: vk::ImageLayout::GENERAL,
                        }];
                        device.update_descriptor_sets(&[write.image_info(&info)], &[]);
                    }
                    Bind::Buffer(buf) => {
                        let info = [vk::DescriptorBufferInfo { buffer: buf.buffer, offset: 0, range: vk::WHOLE_SIZE }];
                        device.update_descriptor_sets(&[write.buffer_info(&info)], &[]);
                    }
                }
            }
            device.cmd_bind_pipeline(self.cb, vk::PipelineBindPoint::COMPUTE, pipeline.pipeline);
            device.cmd_bind_descriptor_sets(self.cb, vk::PipelineBindPoint::COMPUTE, pipeline.layout, 0, &[set], &[]);
            if !push_constants.is_empty() {
                device.cmd_push_constants(self.cb, pipeline.layout, vk::ShaderStageFlags::COMPUTE, 0, push_constants);
            }
        }
        Ok(())
    }
}

/// How many workgroups a dispatch runs.
#[derive(Clone, Copy)]
pub(super) enum Groups<'a> {
    Direct([u32; 3]),
    /// Read from the buffer at the byte offset (VkDispatchIndirectCommand).
    Indirect(&'a GpuBuffer, u64),
}

/// The resources of a dispatch against the shader's declared bindings: one per binding, each
/// of the declared kind.
fn check_binds(shader: &'static str, declared: &[Binding], binds: &[Bind<'_>]) -> GpuResult<()> {
    if binds.len() != declared.len() {
        return Err(GpuError::Binding {
            shader,
            message: format!("{} resources bound to {} declared bindings", binds.len(), declared.len()),
        });
    }
    for (i, (b, d)) in binds.iter().zip(declared).enumerate() {
        let given = match b {
            Bind::Image(_) => BindingKind::StorageImage,
            Bind::Buffer(_) => BindingKind::StorageBuffer,
        };
        if given != d.kind && !(given == BindingKind::StorageBuffer && d.kind == BindingKind::UniformBuffer) {
            return Err(GpuError::Binding {
                shader,
                message: format!("binding {i} ({}) is {} but {given} was bound", d.name, d.kind),
            });
        }
    }
    Ok(())
}
