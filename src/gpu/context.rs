//! Instance, validation, physical-device choice, the one compute queue, the allocator and the
//! persistent pipeline cache.

use super::pool::{Pooled, ResourcePool};
use super::{GpuError, GpuResult, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{c_void, CStr, CString};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to open the GPU.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Enable the Khronos validation layer with synchronization validation.
    pub validation: bool,
    /// Pick a device by index (as listed by `realcam devices`) or by a case-insensitive name substring.
    pub device: Option<String>,
    /// Where the pipeline cache lives; `None` uses `$REALCAM_CACHE_DIR`, then `$XDG_CACHE_HOME/realcam`,
    /// then `~/.cache/realcam`. An empty path disables the persistent cache.
    pub pipeline_cache_dir: Option<PathBuf>,
    /// At most this much GPU memory for a frame's images (`--max-gpu-memory`); a frame that needs
    /// more is rendered in bands. `None`: the device's local heap.
    pub max_memory_bytes: Option<u64>,
    /// Use no subgroup operations even where the device has them: the shaders' variants for
    /// devices without them run instead (tests of those variants).
    pub no_subgroup_ops: bool,
}

impl GpuOptions {
    /// Options from the environment: `REALCAM_VALIDATE=1` turns validation on, `REALCAM_DEVICE` picks a device,
    /// `REALCAM_NO_SUBGROUP_OPS=1` runs the shaders' variants without subgroup operations.
    pub fn from_env() -> Self {
        let validation = std::env::var("REALCAM_VALIDATE").is_ok_and(|v| v != "0" && !v.is_empty());
        let device = std::env::var("REALCAM_DEVICE").ok().filter(|d| !d.is_empty());
        let no_subgroup_ops = std::env::var("REALCAM_NO_SUBGROUP_OPS").is_ok_and(|v| v != "0" && !v.is_empty());
        GpuOptions { validation, device, pipeline_cache_dir: None, max_memory_bytes: None, no_subgroup_ops }
    }
}

/// What the chosen device is, for logs, `--profile` and benchmark tables.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub kind: &'static str,
    pub api_version: String,
    pub driver: String,
}

impl DeviceInfo {
    /// Whether the device runs on the CPU's own cores (a CPU Vulkan driver such as lavapipe).
    pub fn on_cpu(&self) -> bool {
        self.kind == device_kind(vk::PhysicalDeviceType::CPU).0
    }
}

impl std::fmt::Display for DeviceInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}, Vulkan {}, {})", self.name, self.kind, self.api_version, self.driver)
    }
}

/// Validation-layer messages of warning severity or above, counted so tests can require zero.
#[derive(Default)]
pub(crate) struct ValidationLog {
    count: AtomicU64,
    messages: Mutex<Vec<String>>,
}

/// Everything that lives as long as the device. Resources and pipelines hold an `Arc` of it, so
/// the device is destroyed only after the last of them.
pub(crate) struct Shared {
    _entry: ash::Entry,
    pub instance: ash::Instance,
    debug_instance: Option<ash::ext::debug_utils::Instance>,
    messenger: vk::DebugUtilsMessengerEXT,
    validation: Option<Box<ValidationLog>>,
    pub device: ash::Device,
    pub debug_device: Option<ash::ext::debug_utils::Device>,
    sync2_khr: Option<ash::khr::synchronization2::Device>,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub allocator: Mutex<Option<Allocator>>,
    /// Idle images and buffers for the next request of the same kind (src/gpu/pool.rs).
    pub pool: Mutex<ResourcePool>,
    pub pipeline_cache: vk::PipelineCache,
    cache_file: Option<PathBuf>,
    cache_loaded: Vec<u8>,
    pub info: DeviceInfo,
    pub timestamp_period_ns: f64,
    pub timestamps: bool,
    /// The largest width or height of a 2D image (maxImageDimension2D).
    pub max_image_dimension_px: u32,
    /// The size of the largest device-local memory heap, or the user's budget when smaller.
    pub device_local_bytes: u64,
    /// Compute pipelines created so far (see [`Gpu::pipelines_created`]).
    pub pipelines_created: AtomicU64,
    /// Whether compute shaders may broadcast a value within a subgroup (subgroupBroadcast:
    /// VK_SUBGROUP_FEATURE_BALLOT_BIT in the compute stage), unless the options turn it off.
    pub subgroup_broadcast: bool,
    /// The formats whose images live in mapped host memory, linear (see [`Gpu::create_image`]):
    /// on a device that runs on the CPU, those it can store to and copy with linear tiling.
    pub host_image_formats: Vec<vk::Format>,
}

/// The formats realcam's images use.
const HOST_IMAGE_FORMATS: [vk::Format; 3] =
    [vk::Format::R32_SFLOAT, vk::Format::R32G32_SFLOAT, vk::Format::R32G32B32A32_SFLOAT];

/// The opened GPU. Cheap to clone.
#[derive(Clone)]
pub struct Gpu {
    pub(crate) shared: Arc<Shared>,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let text = if data.is_null() || (*data).p_message.is_null() {
        String::from("(no message)")
    } else {
        CStr::from_ptr((*data).p_message).to_string_lossy().into_owned()
    };
    if severity
        .intersects(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
    {
        if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
            log::error!("vulkan validation: {text}");
        } else {
            log::warn!("vulkan validation: {text}");
        }
        if let Some(log) = (user as *const ValidationLog).as_ref() {
            log.count.fetch_add(1, Ordering::SeqCst);
            if let Ok(mut m) = log.messages.lock() {
                m.push(text);
            }
        }
    } else {
        log::debug!("vulkan: {text}");
    }
    vk::FALSE
}

fn device_kind(t: vk::PhysicalDeviceType) -> (&'static str, u32) {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => ("discrete GPU", 4),
        vk::PhysicalDeviceType::INTEGRATED_GPU => ("integrated GPU", 3),
        vk::PhysicalDeviceType::VIRTUAL_GPU => ("virtual GPU", 2),
        vk::PhysicalDeviceType::CPU => ("CPU", 1),
        _ => ("other", 0),
    }
}

fn version_string(v: u32) -> String {
    format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v))
}

/// What [`Gpu::create_instance`] made: the instance, its debug utils and the validation
/// messenger with the log it writes to (null and None without validation).
struct InstanceParts {
    instance: ash::Instance,
    debug_utils: bool,
    debug_instance: Option<ash::ext::debug_utils::Instance>,
    messenger: vk::DebugUtilsMessengerEXT,
    validation_log: Option<Box<ValidationLog>>,
}

impl Gpu {
    /// Open the instance and the best (or the requested) device.
    pub fn new(options: &GpuOptions) -> GpuResult<Gpu> {
        unsafe { Self::open(options) }
    }

    unsafe fn open(options: &GpuOptions) -> GpuResult<Gpu> {
        let entry = ash::Entry::load().map_err(|e| GpuError::Loader(e.to_string()))?;

        let InstanceParts { instance, debug_utils, debug_instance, messenger, validation_log } =
            Self::create_instance(&entry, options)?;

        // From here on, failures must tear down what exists.
        let result = Self::open_device(&instance, options);
        let (physical_device, info, queue_family) = match result {
            Ok(v) => v,
            Err(e) => {
                if let Some(d) = &debug_instance {
                    d.destroy_debug_utils_messenger(messenger, None);
                }
                instance.destroy_instance(None);
                return Err(e);
            }
        };

        let props = instance.get_physical_device_properties(physical_device);
        let core13 = props.api_version >= vk::API_VERSION_1_3;
        let device = match Self::create_device(&instance, physical_device, queue_family, core13) {
            Ok(d) => d,
            Err(result) => {
                if let Some(d) = &debug_instance {
                    d.destroy_debug_utils_messenger(messenger, None);
                }
                instance.destroy_instance(None);
                return Err(GpuError::Vk { call: "vkCreateDevice", result });
            }
        };
        let queue = device.get_device_queue(queue_family, 0);
        let debug_device = debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let sync2_khr = (!core13).then(|| ash::khr::synchronization2::Device::new(&instance, &device));

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|source| GpuError::Alloc { name: "allocator".into(), source })?;

        let cache_file = cache_path(options, &props);
        let cache_loaded = cache_file.as_ref().and_then(|p| std::fs::read(p).ok()).unwrap_or_default();
        // A stale or foreign cache is harmless: the driver checks the header and ignores it.
        let cache_info = vk::PipelineCacheCreateInfo::default().initial_data(&cache_loaded);
        let pipeline_cache = device
            .create_pipeline_cache(&cache_info, None)
            .or_else(|_| device.create_pipeline_cache(&vk::PipelineCacheCreateInfo::default(), None))
            .vk("vkCreatePipelineCache")?;

        let families = instance.get_physical_device_queue_family_properties(physical_device);
        let timestamps =
            families[queue_family as usize].timestamp_valid_bits > 0 && props.limits.timestamp_period > 0.0;

        let device_local_bytes = match (Self::device_local_bytes(&instance, physical_device), options.max_memory_bytes)
        {
            (heap, Some(budget)) if heap == 0 || budget < heap => budget,
            (heap, _) => heap,
        };
        let host_image_formats = Self::host_image_formats(&instance, physical_device, &info);
        let subgroup_broadcast = !options.no_subgroup_ops && Self::has_subgroup_broadcast(&instance, physical_device);
        log::info!("GPU: {info}");
        let shared = Shared {
            _entry: entry,
            instance,
            debug_instance,
            messenger,
            validation: validation_log,
            device,
            debug_device,
            sync2_khr,
            queue,
            queue_family,
            allocator: Mutex::new(Some(allocator)),
            pool: Mutex::new(ResourcePool::default()),
            pipeline_cache,
            cache_file,
            cache_loaded,
            info,
            timestamp_period_ns: props.limits.timestamp_period as f64,
            timestamps,
            max_image_dimension_px: props.limits.max_image_dimension2_d,
            device_local_bytes,
            pipelines_created: AtomicU64::new(0),
            host_image_formats,
            subgroup_broadcast,
        };
        let gpu = Gpu { shared: Arc::new(shared) };
        gpu.set_name(gpu.shared.queue, "realcam compute queue");
        Ok(gpu)
    }

    /// The instance, with debug utils where the loader has them and the validation layer
    /// (its messages to a [`ValidationLog`]) when asked for.
    unsafe fn create_instance(entry: &ash::Entry, options: &GpuOptions) -> GpuResult<InstanceParts> {
        // The layers are listed only to find the validation layer: the loader reads every layer's
        // manifest and loads the implicit ones' libraries for the list (lavapipe on 2 cores:
        // 3-7 ms of the 28-31 ms it takes to open the GPU), which a run without validation
        // does not need.
        if options.validation {
            let layers = entry.enumerate_instance_layer_properties().vk("vkEnumerateInstanceLayerProperties")?;
            if !layers.iter().any(|l| l.layer_name_as_c_str() == Ok(VALIDATION_LAYER)) {
                return Err(GpuError::NoValidationLayer);
            }
        }
        let exts = entry.enumerate_instance_extension_properties(None).vk("vkEnumerateInstanceExtensionProperties")?;
        let has_ext = |name: &CStr| exts.iter().any(|e| e.extension_name_as_c_str() == Ok(name));
        // Debug utils is always enabled when present: object names and pass labels show up in
        // RenderDoc, Nsight and Radeon GPU Profiler even without validation.
        let debug_utils = has_ext(ash::ext::debug_utils::NAME);

        let mut ext_names = Vec::new();
        if debug_utils {
            ext_names.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let mut layer_names = Vec::new();
        if options.validation {
            layer_names.push(VALIDATION_LAYER.as_ptr());
            // VK_EXT_validation_features is provided by the layer itself.
            ext_names.push(ash::ext::validation_features::NAME.as_ptr());
        }

        let app_name = CString::new("realcam").unwrap_or_default();
        let app = vk::ApplicationInfo::default()
            .application_name(&app_name)
            .application_version(vk::make_api_version(0, 0, 1, 0))
            .engine_name(&app_name)
            .api_version(vk::API_VERSION_1_3);
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);

        let validation_log = options.validation.then(|| Box::new(ValidationLog::default()));
        let severity = vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
            | vk::DebugUtilsMessageSeverityFlagsEXT::INFO;
        let types = vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
            | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE;
        let user_ptr =
            validation_log.as_ref().map_or(std::ptr::null_mut(), |b| &**b as *const ValidationLog as *mut c_void);
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(severity)
            .message_type(types)
            .pfn_user_callback(Some(debug_callback))
            .user_data(user_ptr);

        let mut create_info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_names)
            .enabled_extension_names(&ext_names);
        if options.validation {
            // Chained so that instance creation itself is validated too.
            create_info = create_info.push_next(&mut validation_features).push_next(&mut messenger_info);
        }
        let instance = entry.create_instance(&create_info, None).vk("vkCreateInstance")?;

        let debug_instance = debug_utils.then(|| ash::ext::debug_utils::Instance::new(entry, &instance));
        let messenger = match (&debug_instance, options.validation) {
            (Some(d), true) => d
                // A copy without the instance chain: this call's pNext must be null.
                .create_debug_utils_messenger(&messenger_info.push_next_cleared(), None)
                .vk("vkCreateDebugUtilsMessengerEXT")?,
            _ => vk::DebugUtilsMessengerEXT::null(),
        };
        Ok(InstanceParts { instance, debug_utils, debug_instance, messenger, validation_log })
    }

    /// The logical device with one queue of `queue_family` and synchronization2 (core in
    /// Vulkan 1.3, else the KHR extension).
    unsafe fn create_device(
        instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
        queue_family: u32,
        core13: bool,
    ) -> Result<ash::Device, vk::Result> {
        let priorities = [1.0f32];
        let queue_infos =
            [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&priorities)];
        let mut dev_exts = Vec::new();
        if !core13 {
            dev_exts.push(ash::khr::synchronization2::NAME.as_ptr());
        }
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default().synchronization2(true);
        let mut sync2 = vk::PhysicalDeviceSynchronization2Features::default().synchronization2(true);
        let mut device_info =
            vk::DeviceCreateInfo::default().queue_create_infos(&queue_infos).enabled_extension_names(&dev_exts);
        device_info = if core13 { device_info.push_next(&mut f13) } else { device_info.push_next(&mut sync2) };
        instance.create_device(physical_device, &device_info, None)
    }

    /// The size of the largest device-local memory heap (bytes).
    unsafe fn device_local_bytes(instance: &ash::Instance, physical_device: vk::PhysicalDevice) -> u64 {
        let memory = instance.get_physical_device_memory_properties(physical_device);
        memory.memory_heaps[..(memory.memory_heap_count as usize).min(vk::MAX_MEMORY_HEAPS)]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0)
    }

    /// Whether the device's compute stage has subgroup ballot operations (subgroupBroadcast).
    unsafe fn has_subgroup_broadcast(instance: &ash::Instance, physical_device: vk::PhysicalDevice) -> bool {
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup);
        instance.get_physical_device_properties2(physical_device, &mut props2);
        subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
            && subgroup.supported_operations.contains(vk::SubgroupFeatureFlags::BALLOT)
    }

    /// The formats of [`HOST_IMAGE_FORMATS`] a CPU device can keep as linear storage images.
    unsafe fn host_image_formats(
        instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
        info: &DeviceInfo,
    ) -> Vec<vk::Format> {
        match info.on_cpu() {
            true => HOST_IMAGE_FORMATS
                .into_iter()
                .filter(|&f| {
                    let linear =
                        instance.get_physical_device_format_properties(physical_device, f).linear_tiling_features;
                    linear.contains(
                        vk::FormatFeatureFlags::STORAGE_IMAGE
                            | vk::FormatFeatureFlags::TRANSFER_SRC
                            | vk::FormatFeatureFlags::TRANSFER_DST,
                    )
                })
                .collect(),
            false => Vec::new(),
        }
    }

    /// Choose the physical device: `--device` if given, else discrete > integrated > virtual > CPU.
    unsafe fn open_device(
        instance: &ash::Instance,
        options: &GpuOptions,
    ) -> GpuResult<(vk::PhysicalDevice, DeviceInfo, u32)> {
        let devices = instance.enumerate_physical_devices().vk("vkEnumeratePhysicalDevices")?;
        if devices.is_empty() {
            return Err(GpuError::NoDevice);
        }
        let infos: Vec<DeviceInfo> =
            devices.iter().enumerate().map(|(index, &pd)| describe(instance, pd, index)).collect();
        let chosen = match &options.device {
            Some(wanted) => {
                let by_index = wanted.parse::<usize>().ok().filter(|&i| i < devices.len());
                let lower = wanted.to_lowercase();
                by_index.or_else(|| infos.iter().position(|i| i.name.to_lowercase().contains(&lower))).ok_or_else(
                    || GpuError::DeviceNotFound {
                        wanted: wanted.clone(),
                        found: infos.iter().map(|i| format!("[{}] {}", i.index, i.name)).collect::<Vec<_>>().join(", "),
                    },
                )?
            }
            None => (0..devices.len())
                .max_by_key(|&i| {
                    let props = instance.get_physical_device_properties(devices[i]);
                    // Stable preference: type first, then the earliest enumerated.
                    (device_kind(props.device_type).1, std::cmp::Reverse(i))
                })
                .unwrap_or(0),
        };
        let pd = devices[chosen];
        let props = instance.get_physical_device_properties(pd);
        let name = infos[chosen].name.clone();
        if props.api_version < vk::API_VERSION_1_2 {
            return Err(GpuError::Unsuitable { name, why: format!("Vulkan {} < 1.2", infos[chosen].api_version) });
        }
        let families = instance.get_physical_device_queue_family_properties(pd);
        let family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .ok_or_else(|| GpuError::Unsuitable { name: name.clone(), why: "no compute queue".into() })?;
        Ok((pd, infos[chosen].clone(), family as u32))
    }

    /// Every device the loader sees, for `realcam devices`.
    pub fn list_devices() -> GpuResult<Vec<DeviceInfo>> {
        unsafe {
            let entry = ash::Entry::load().map_err(|e| GpuError::Loader(e.to_string()))?;
            let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
            let instance = entry
                .create_instance(&vk::InstanceCreateInfo::default().application_info(&app), None)
                .vk("vkCreateInstance")?;
            let devices = instance.enumerate_physical_devices().vk("vkEnumeratePhysicalDevices");
            let out = devices.map(|d| d.iter().enumerate().map(|(i, &pd)| describe(&instance, pd, i)).collect());
            instance.destroy_instance(None);
            out
        }
    }

    /// Errors unless `bytes` of images of `width` x `height` px fit this device: each side at
    /// most maxImageDimension2D, the total at most its largest device-local heap.
    pub fn check_fits(&self, width: u32, height: u32, bytes: u64) -> GpuResult<()> {
        let s = &self.shared;
        let max_px = s.max_image_dimension_px;
        let heap = s.device_local_bytes;
        if width > max_px || height > max_px || (heap > 0 && bytes > heap) {
            return Err(GpuError::TooLarge { device: s.info.name.clone(), width, height, max_px, bytes, heap });
        }
        Ok(())
    }

    /// The GPU memory a frame's images may take (bytes): the device's local heap, or less when
    /// [`GpuOptions::max_memory_bytes`] says so; 0 when the device does not say.
    pub fn memory_budget_bytes(&self) -> u64 {
        self.shared.device_local_bytes
    }

    /// The largest width or height of an image on this device (maxImageDimension2D).
    pub fn max_image_dimension_px(&self) -> u32 {
        self.shared.max_image_dimension_px
    }

    pub fn info(&self) -> &DeviceInfo {
        &self.shared.info
    }

    /// Whether compute shaders may use subgroupBroadcast (see [`GpuOptions::no_subgroup_ops`]);
    /// passes whose shader has a variant without subgroup operations pick it where not.
    pub fn subgroup_broadcast(&self) -> bool {
        self.shared.subgroup_broadcast
    }

    /// The device memory in use now (the live allocations) and held (the allocator's blocks,
    /// used or not), in bytes.
    pub fn memory_bytes(&self) -> (u64, u64) {
        let guard = self.shared.allocator.lock().unwrap_or_else(|e| e.into_inner());
        guard.as_ref().map_or((0, 0), |a| {
            let report = a.generate_report();
            (report.total_allocated_bytes, report.total_reserved_bytes)
        })
    }

    /// Writes the pipeline cache to its file if it holds anything new (closing the device does
    /// too; this is for a process that ends without closing it).
    pub fn save_pipeline_cache(&self) {
        self.shared.save_pipeline_cache();
    }

    pub(crate) fn device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// Validation messages of warning severity or above since the device was opened.
    pub fn validation_message_count(&self) -> u64 {
        self.shared.validation.as_ref().map_or(0, |v| v.count.load(Ordering::SeqCst))
    }

    /// The texts of those messages.
    pub fn validation_messages(&self) -> Vec<String> {
        self.shared.validation.as_ref().and_then(|v| v.messages.lock().ok().map(|m| m.clone())).unwrap_or_default()
    }

    pub fn validation_enabled(&self) -> bool {
        self.shared.validation.is_some()
    }

    /// Name a Vulkan object for debuggers and validation messages.
    /// Destroy the idle images and buffers the pool keeps for the next frame (a long-lived
    /// process between jobs; a render lets its pool go with the device).
    pub fn trim_pool(&self) {
        self.shared.trim_pool();
    }

    /// How many compute pipelines this device has created (each compiles a shader: on lavapipe
    /// 1-25 ms of CPU).
    pub fn pipelines_created(&self) -> u64 {
        self.shared.pipelines_created.load(Ordering::Relaxed)
    }

    /// The pool's idle resources: how many, and their bytes.
    pub fn pool_idle(&self) -> (usize, u64) {
        self.shared.pool.lock().map(|p| (p.idle_count(), p.idle_bytes())).unwrap_or((0, 0))
    }

    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(d) = &self.shared.debug_device {
            if let Ok(name) = CString::new(name) {
                let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&name);
                // Naming is best effort: a failure only loses a label.
                let _ = unsafe { d.set_debug_utils_object_name(&info) };
            }
        }
    }

    /// vkCmdPipelineBarrier2 from core 1.3 or VK_KHR_synchronization2 on 1.2 devices.
    pub(crate) unsafe fn cmd_barrier(&self, cb: vk::CommandBuffer, dependency: &vk::DependencyInfo<'_>) {
        match &self.shared.sync2_khr {
            Some(k) => k.cmd_pipeline_barrier2(cb, dependency),
            None => self.shared.device.cmd_pipeline_barrier2(cb, dependency),
        }
    }

    pub(crate) unsafe fn cmd_timestamp(&self, cb: vk::CommandBuffer, pool: vk::QueryPool, index: u32) {
        let stage = vk::PipelineStageFlags2::ALL_COMMANDS;
        match &self.shared.sync2_khr {
            Some(k) => k.cmd_write_timestamp2(cb, stage, pool, index),
            None => self.shared.device.cmd_write_timestamp2(cb, stage, pool, index),
        }
    }

    pub(crate) unsafe fn submit_and_wait(&self, cb: vk::CommandBuffer) -> GpuResult<()> {
        let device = &self.shared.device;
        let fence = device.create_fence(&vk::FenceCreateInfo::default(), None).vk("vkCreateFence")?;
        let cbs = [cb];
        let submit = vk::SubmitInfo::default().command_buffers(&cbs);
        let result = device
            .queue_submit(self.shared.queue, &[submit], fence)
            .vk("vkQueueSubmit")
            .and_then(|_| device.wait_for_fences(&[fence], true, u64::MAX).vk("vkWaitForFences"));
        device.destroy_fence(fence, None);
        result
    }
}

unsafe fn describe(instance: &ash::Instance, pd: vk::PhysicalDevice, index: usize) -> DeviceInfo {
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
    instance.get_physical_device_properties2(pd, &mut props2);
    let props = props2.properties;
    let driver_text = format!(
        "{} {}",
        driver.driver_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        driver.driver_info_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
    );
    DeviceInfo {
        index,
        name: props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        kind: device_kind(props.device_type).0,
        api_version: version_string(props.api_version),
        driver: driver_text.trim().to_string(),
    }
}

fn cache_path(options: &GpuOptions, props: &vk::PhysicalDeviceProperties) -> Option<PathBuf> {
    let dir = match &options.pipeline_cache_dir {
        Some(d) if d.as_os_str().is_empty() => return None,
        Some(d) => d.clone(),
        None => std::env::var_os("REALCAM_CACHE_DIR")
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("XDG_CACHE_HOME").map(|x| PathBuf::from(x).join("realcam")))
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache").join("realcam")))?,
    };
    let uuid: String = props.pipeline_cache_uuid.iter().map(|b| format!("{b:02x}")).collect();
    Some(
        dir.join(format!(
            "pipelines-{:04x}-{:04x}-{}-{uuid}.bin",
            props.vendor_id, props.device_id, props.driver_version
        )),
    )
}

impl Shared {
    /// An image or buffer dropped after its work completed: kept idle for the next request of
    /// the same kind, unless the device is being destroyed; what no longer fits is destroyed.
    pub(crate) fn release(&self, item: Pooled) {
        let evicted = match self.pool.lock() {
            Ok(mut pool) => pool.keep(item),
            Err(_) => vec![item],
        };
        self.destroy_pooled(evicted);
    }

    /// Destroy every idle image and buffer (their memory back to the allocator).
    pub(crate) fn trim_pool(&self) {
        let idle = self.pool.lock().map(|mut p| p.drain()).unwrap_or_default();
        self.destroy_pooled(idle);
    }

    fn destroy_pooled(&self, items: Vec<Pooled>) {
        if items.is_empty() {
            return;
        }
        let allocations: Vec<_> = items.into_iter().map(|i| i.destroy(&self.device)).collect();
        if let Ok(mut guard) = self.allocator.lock() {
            if let Some(allocator) = guard.as_mut() {
                for a in allocations {
                    let _ = allocator.free(a);
                }
            }
        }
    }

    /// Write the pipeline cache back if it grew, to a temporary file renamed into place, so
    /// parallel processes on a farm never read a half-written cache.
    fn save_pipeline_cache(&self) {
        let Some(path) = &self.cache_file else { return };
        let Ok(data) = (unsafe { self.device.get_pipeline_cache_data(self.pipeline_cache) }) else { return };
        if data == self.cache_loaded || data.is_empty() {
            return;
        }
        let Some(dir) = path.parent() else { return };
        if std::fs::create_dir_all(dir).is_err() {
            return;
        }
        // Unique per device, not only per process: devices of one process (tests on threads, a
        // session's renderers) may save at the same moment, and one temporary shared by two
        // writers could be renamed half written.
        static SAVES: AtomicU64 = AtomicU64::new(0);
        let n = SAVES.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".pipelines.tmp-{}-{n}", std::process::id()));
        if std::fs::write(&tmp, &data).and_then(|_| std::fs::rename(&tmp, path)).is_err() {
            let _ = std::fs::remove_file(&tmp);
            log::debug!("could not save the pipeline cache to {}", path.display());
        }
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        unsafe {
            let _ = self.device.device_wait_idle();
            self.save_pipeline_cache();
            self.device.destroy_pipeline_cache(self.pipeline_cache, None);
            self.trim_pool();
            if let Ok(mut a) = self.allocator.lock() {
                a.take();
            }
            self.device.destroy_device(None);
            if let Some(d) = &self.debug_instance {
                if self.messenger != vk::DebugUtilsMessengerEXT::null() {
                    d.destroy_debug_utils_messenger(self.messenger, None);
                }
            }
            self.instance.destroy_instance(None);
        }
    }
}

trait ClearNext {
    fn push_next_cleared(&self) -> Self;
}

impl ClearNext for vk::DebugUtilsMessengerCreateInfoEXT<'_> {
    fn push_next_cleared(&self) -> Self {
        let mut copy = *self;
        copy.p_next = std::ptr::null();
        copy
    }
}
