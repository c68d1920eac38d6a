//! One WGSL shader module with the bind group of buffers all its kernels share: the host side
//! every kernel family (`traverse.wgsl`, `render.wgsl`, `whitted.wgsl`) needs, written once.
//!
//! Every binding of a family is a buffer seen by compute shaders, numbered from 0 in the
//! order given, so a layout is a list of [`BufferBindingType`]s and a bind group a list of
//! buffers in the same order.

use wgpu::BufferBindingType;

/// A storage buffer the kernels only read.
pub(crate) const READ: BufferBindingType = BufferBindingType::Storage { read_only: true };
/// A storage buffer the kernels write.
pub(crate) const WRITE: BufferBindingType = BufferBindingType::Storage { read_only: false };
/// A uniform block.
pub(crate) const UNIFORM: BufferBindingType = BufferBindingType::Uniform;

/// A compiled shader module and the layout of the one bind group its kernels use.
#[derive(Debug)]
pub(crate) struct Program {
    /// The bind group's layout, for [`Program::bind`].
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
}

impl Program {
    /// Compiles `source` (the file `{name}.wgsl`, perhaps edited) with bindings `0..` of
    /// `bindings`' types.
    pub(crate) fn new(
        device: &wgpu::Device,
        name: &str,
        source: String,
        bindings: &[BufferBindingType],
    ) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&format!("cobalt {name}.wgsl")),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let entries: Vec<wgpu::BindGroupLayoutEntry> = (0u32..)
            .zip(bindings)
            .map(|(binding, &ty)| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(&format!("cobalt {name} bind group layout")),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(&format!("cobalt {name} pipeline layout")),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        Self {
            layout,
            pipeline_layout,
            module,
        }
    }

    /// The kernel `entry` as a pipeline, with the module's own constants.
    pub(crate) fn pipeline(
        &self,
        device: &wgpu::Device,
        entry: &str,
        label: &str,
    ) -> wgpu::ComputePipeline {
        self.pipeline_with(device, entry, label, Default::default())
    }

    /// The kernel `entry` as a pipeline compiled with `options` (override constants).
    pub(crate) fn pipeline_with(
        &self,
        device: &wgpu::Device,
        entry: &str,
        label: &str,
        options: wgpu::PipelineCompilationOptions,
    ) -> wgpu::ComputePipeline {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: Some(&self.pipeline_layout),
            module: &self.module,
            entry_point: Some(entry),
            compilation_options: options,
            cache: None,
        })
    }

    /// A bind group of `buffers`, binding `k` the `k`-th.
    pub(crate) fn bind(
        &self,
        device: &wgpu::Device,
        label: &str,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let whole: Vec<_> = buffers
            .iter()
            .map(|b| b.as_entire_buffer_binding())
            .collect();
        self.bind_ranges(device, label, &whole)
    }

    /// A bind group of `ranges` of buffers, binding `k` the `k`-th.
    pub(crate) fn bind_ranges(
        &self,
        device: &wgpu::Device,
        label: &str,
        ranges: &[wgpu::BufferBinding],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = (0u32..)
            .zip(ranges)
            .map(|(binding, b)| wgpu::BindGroupEntry {
                binding,
                resource: wgpu::BindingResource::Buffer(b.clone()),
            })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &self.layout,
            entries: &entries,
        })
    }
}

/// A shader module of one kernel, its entry point `main`: the small kernels a launch records
/// besides the traces (its counts, an estimate's sums, the verdict).
#[derive(Debug)]
pub(crate) struct Kernel {
    pub(crate) program: Program,
    pub(crate) pipeline: wgpu::ComputePipeline,
}

impl Kernel {
    /// Compiles `source` (the file `{name}.wgsl`) with bindings of `bindings`' types.
    pub(crate) fn new(
        device: &wgpu::Device,
        name: &str,
        source: &str,
        bindings: &[BufferBindingType],
    ) -> Self {
        let program = Program::new(device, name, source.to_string(), bindings);
        let pipeline = program.pipeline(device, "main", &format!("cobalt {name} pipeline"));
        Self { program, pipeline }
    }
}
