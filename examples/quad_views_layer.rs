//! A test OpenXR API layer that offers `XR_VARJO_quad_views` on top of a
//! stereo runtime (Monado here), so that vergence's submission of the
//! inset as four views can run end to end without a Varjo headset. It is
//! built as a shared library (`cargo build --example quad_views_layer`)
//! and enabled through the loader (`XR_API_LAYER_PATH` naming a folder with
//! its manifest, `XR_ENABLE_API_LAYERS`); `tests/xr.rs` writes the manifest.
//!
//! What it does, after the extension's specification
//! (<https://registry.khronos.org/OpenXR/specs/1.1/html/xrspec.html#XR_VARJO_quad_views>):
//! - lists `XR_VIEW_CONFIGURATION_TYPE_PRIMARY_QUAD_VARJO` after the
//!   runtime's configurations when the application enabled the extension,
//!   or asked for OpenXR 1.1 (whose core
//!   `PRIMARY_STEREO_WITH_FOVEATED_INSET` is the same value: a manifest
//!   without the extension tests that path), with four views: the runtime's two stereo
//!   views (the context views) and two focus views with the same pose, a
//!   FOV of [`FOCUS_TAN`] × the eye's tangents on each side, and a
//!   recommended size of that fraction of the eye's (the same density;
//!   `VERGENCE_QUAD_LAYER_CONTEXT_SCALE` recommends the context views at a
//!   lower density, as Varjo's are);
//! - begins the runtime's session as stereo, locates the four views from
//!   the runtime's two, and answers blend modes, properties and visibility
//!   masks of the quad configuration with the stereo one's (the focus
//!   views have no hidden area);
//! - at `xrEndFrame` passes the context views of a four-view projection
//!   layer on to the runtime (a stereo runtime cannot show the focus views;
//!   a quad-views runtime composites them) and, when
//!   `VERGENCE_QUAD_LAYER_LOG` names a file, appends one JSON line per
//!   projection layer: the views' FOVs and sub-image rectangles.
//!
//! It is a test fixture, not a product: one instance at a time, and it
//! strips the extension from the instance it creates below it.

use openxr::sys;
use openxr::sys::Handle;
use std::ffi::{c_char, CStr};
use std::io::Write;
use std::sync::Mutex;

/// The layer's name, as in its manifest.
const LAYER_NAME: &str = "XR_APILAYER_VERGENCE_quad_views";
/// The extension the layer adds.
const EXTENSION: &str = "XR_VARJO_quad_views";
/// The focus views' half-extent as a fraction of the eye's, in tangents.
const FOCUS_TAN: f32 = 0.4;
const QUAD: sys::ViewConfigurationType = sys::ViewConfigurationType::PRIMARY_QUAD_VARJO;
const STEREO: sys::ViewConfigurationType = sys::ViewConfigurationType::PRIMARY_STEREO;

/// The next layer's (or runtime's) entry points.
#[derive(Clone, Copy)]
struct Next {
    gipa: sys::pfn::GetInstanceProcAddr,
    configurations: sys::pfn::EnumerateViewConfigurations,
    properties: sys::pfn::GetViewConfigurationProperties,
    views: sys::pfn::EnumerateViewConfigurationViews,
    blend: sys::pfn::EnumerateEnvironmentBlendModes,
    begin: sys::pfn::BeginSession,
    locate: sys::pfn::LocateViews,
    end: sys::pfn::EndFrame,
    mask: Option<sys::pfn::GetVisibilityMaskKHR>,
    /// The application enabled the extension or asked for OpenXR 1.1,
    /// whose core has the same view configuration.
    offered: bool,
}

static NEXT: Mutex<Option<Next>> = Mutex::new(None);

fn next() -> Option<Next> {
    *NEXT.lock().unwrap_or_else(|e| e.into_inner())
}

/// The loader's first call: the layer's interface version and entry
/// points.
///
/// # Safety
/// Called by the OpenXR loader with valid structures.
#[no_mangle]
pub unsafe extern "system" fn xrNegotiateLoaderApiLayerInterface(
    loader: *const sys::NegotiateLoaderInfo,
    _name: *const c_char,
    request: *mut sys::NegotiateApiLayerRequest,
) -> sys::Result {
    let (Some(loader), Some(request)) = (loader.as_ref(), request.as_mut()) else {
        return sys::Result::ERROR_INITIALIZATION_FAILED;
    };
    let ours = sys::Version::new(1, 1, 0);
    if loader.struct_type != sys::NegotiateLoaderInfo::TYPE
        || request.struct_type != sys::NegotiateApiLayerRequest::TYPE
        || loader.min_interface_version > 1
        || loader.max_interface_version < 1
        || loader.min_api_version > ours
    {
        return sys::Result::ERROR_INITIALIZATION_FAILED;
    }
    request.layer_interface_version = 1;
    request.layer_api_version = ours;
    request.get_instance_proc_addr = Some(get_instance_proc_addr);
    request.create_api_layer_instance = Some(create_api_layer_instance);
    sys::Result::SUCCESS
}

/// Looks `name` up in the next layer.
unsafe fn lookup(
    gipa: sys::pfn::GetInstanceProcAddr,
    inst: sys::Instance,
    name: &CStr,
) -> Option<sys::pfn::VoidFunction> {
    let mut f = None;
    let r = gipa(inst, name.as_ptr(), &mut f);
    if r == sys::Result::SUCCESS {
        f
    } else {
        None
    }
}

unsafe extern "system" fn create_api_layer_instance(
    info: *const sys::InstanceCreateInfo,
    layer_info: *const sys::ApiLayerCreateInfo,
    instance: *mut sys::Instance,
) -> sys::Result {
    let (Some(info), Some(layer_info)) = (info.as_ref(), layer_info.as_ref()) else {
        return sys::Result::ERROR_INITIALIZATION_FAILED;
    };
    let Some(ours) = layer_info.next_info.as_ref() else {
        return sys::Result::ERROR_INITIALIZATION_FAILED;
    };
    let (Some(gipa), Some(create)) = (
        ours.next_get_instance_proc_addr,
        ours.next_create_api_layer_instance,
    ) else {
        return sys::Result::ERROR_INITIALIZATION_FAILED;
    };
    let name = CStr::from_ptr(ours.layer_name.as_ptr());
    if name.to_bytes() != LAYER_NAME.as_bytes() {
        return sys::Result::ERROR_INITIALIZATION_FAILED;
    }
    // The layers below do not know the extension.
    let asked: Vec<*const c_char> = (0..info.enabled_extension_count as usize)
        .map(|i| *info.enabled_extension_names.add(i))
        .collect();
    let offered = asked
        .iter()
        .any(|&n| CStr::from_ptr(n).to_bytes() == EXTENSION.as_bytes())
        || info.application_info.api_version >= sys::Version::new(1, 1, 0);
    let names: Vec<*const c_char> = asked
        .into_iter()
        .filter(|&n| CStr::from_ptr(n).to_bytes() != EXTENSION.as_bytes())
        .collect();
    let mut below = *info;
    below.enabled_extension_count = names.len() as u32;
    below.enabled_extension_names = names.as_ptr();
    let mut chain = *layer_info;
    chain.next_info = ours.next;
    let r = create(&below, &chain, instance);
    if r.into_raw() < 0 {
        return r;
    }
    let inst = *instance;
    macro_rules! get {
        ($name:literal, $ty:ty) => {
            match lookup(gipa, inst, $name) {
                Some(f) => std::mem::transmute::<sys::pfn::VoidFunction, $ty>(f),
                None => return sys::Result::ERROR_INITIALIZATION_FAILED,
            }
        };
    }
    let n = Next {
        gipa,
        configurations: get!(
            c"xrEnumerateViewConfigurations",
            sys::pfn::EnumerateViewConfigurations
        ),
        properties: get!(
            c"xrGetViewConfigurationProperties",
            sys::pfn::GetViewConfigurationProperties
        ),
        views: get!(
            c"xrEnumerateViewConfigurationViews",
            sys::pfn::EnumerateViewConfigurationViews
        ),
        blend: get!(
            c"xrEnumerateEnvironmentBlendModes",
            sys::pfn::EnumerateEnvironmentBlendModes
        ),
        begin: get!(c"xrBeginSession", sys::pfn::BeginSession),
        locate: get!(c"xrLocateViews", sys::pfn::LocateViews),
        end: get!(c"xrEndFrame", sys::pfn::EndFrame),
        mask: lookup(gipa, inst, c"xrGetVisibilityMaskKHR").map(|f| {
            std::mem::transmute::<sys::pfn::VoidFunction, sys::pfn::GetVisibilityMaskKHR>(f)
        }),
        offered,
    };
    *NEXT.lock().unwrap_or_else(|e| e.into_inner()) = Some(n);
    r
}

unsafe extern "system" fn get_instance_proc_addr(
    instance: sys::Instance,
    name: *const c_char,
    function: *mut Option<sys::pfn::VoidFunction>,
) -> sys::Result {
    if name.is_null() || function.is_null() {
        return sys::Result::ERROR_VALIDATION_FAILURE;
    }
    // A hook as the loader's untyped function pointer.
    macro_rules! hook {
        ($ty:ty, $f:expr) => {
            Some(std::mem::transmute::<$ty, sys::pfn::VoidFunction>($f))
        };
    }
    use sys::pfn;
    let hooked: Option<pfn::VoidFunction> = match CStr::from_ptr(name).to_bytes() {
        b"xrGetInstanceProcAddr" => hook!(pfn::GetInstanceProcAddr, get_instance_proc_addr),
        b"xrEnumerateViewConfigurations" => {
            hook!(
                pfn::EnumerateViewConfigurations,
                enumerate_view_configurations
            )
        }
        b"xrGetViewConfigurationProperties" => hook!(
            pfn::GetViewConfigurationProperties,
            get_view_configuration_properties
        ),
        b"xrEnumerateViewConfigurationViews" => hook!(
            pfn::EnumerateViewConfigurationViews,
            enumerate_view_configuration_views
        ),
        b"xrEnumerateEnvironmentBlendModes" => hook!(
            pfn::EnumerateEnvironmentBlendModes,
            enumerate_environment_blend_modes
        ),
        b"xrBeginSession" => hook!(pfn::BeginSession, begin_session),
        b"xrLocateViews" => hook!(pfn::LocateViews, locate_views),
        b"xrEndFrame" => hook!(pfn::EndFrame, end_frame),
        b"xrGetVisibilityMaskKHR" if next().is_some_and(|n| n.mask.is_some()) => {
            hook!(pfn::GetVisibilityMaskKHR, get_visibility_mask)
        }
        _ => None,
    };
    if let Some(f) = hooked {
        *function = Some(f);
        return sys::Result::SUCCESS;
    }
    match next() {
        Some(n) => (n.gipa)(instance, name, function),
        None => {
            *function = None;
            sys::Result::ERROR_HANDLE_INVALID
        }
    }
}

/// Writes `items` through the two-call idiom, each into its output
/// element by `put` (which keeps what the application's structure must
/// keep: its type and chain).
unsafe fn fill_with<T, U>(
    items: &[T],
    capacity: u32,
    count: *mut u32,
    out: *mut U,
    put: impl Fn(&mut U, &T),
) -> sys::Result {
    if count.is_null() {
        return sys::Result::ERROR_VALIDATION_FAILURE;
    }
    *count = items.len() as u32;
    if capacity == 0 {
        return sys::Result::SUCCESS;
    }
    if (capacity as usize) < items.len() || out.is_null() {
        return sys::Result::ERROR_SIZE_INSUFFICIENT;
    }
    for (i, item) in items.iter().enumerate() {
        put(&mut *out.add(i), item);
    }
    sys::Result::SUCCESS
}

unsafe extern "system" fn enumerate_view_configurations(
    instance: sys::Instance,
    system: sys::SystemId,
    capacity: u32,
    count: *mut u32,
    out: *mut sys::ViewConfigurationType,
) -> sys::Result {
    let Some(n) = next() else {
        return sys::Result::ERROR_HANDLE_INVALID;
    };
    let mut len = 0;
    let r = (n.configurations)(instance, system, 0, &mut len, std::ptr::null_mut());
    if r.into_raw() < 0 {
        return r;
    }
    let mut types = vec![STEREO; len as usize];
    let r = (n.configurations)(instance, system, len, &mut len, types.as_mut_ptr());
    if r.into_raw() < 0 {
        return r;
    }
    types.truncate(len as usize);
    if n.offered && types.contains(&STEREO) {
        types.push(QUAD);
    }
    fill_with(&types, capacity, count, out, |o, t| *o = *t)
}

unsafe extern "system" fn get_view_configuration_properties(
    instance: sys::Instance,
    system: sys::SystemId,
    ty: sys::ViewConfigurationType,
    props: *mut sys::ViewConfigurationProperties,
) -> sys::Result {
    let Some(n) = next() else {
        return sys::Result::ERROR_HANDLE_INVALID;
    };
    if ty != QUAD {
        return (n.properties)(instance, system, ty, props);
    }
    let r = (n.properties)(instance, system, STEREO, props);
    if r == sys::Result::SUCCESS {
        (*props).view_configuration_type = QUAD;
    }
    r
}

unsafe extern "system" fn enumerate_view_configuration_views(
    instance: sys::Instance,
    system: sys::SystemId,
    ty: sys::ViewConfigurationType,
    capacity: u32,
    count: *mut u32,
    out: *mut sys::ViewConfigurationView,
) -> sys::Result {
    let Some(n) = next() else {
        return sys::Result::ERROR_HANDLE_INVALID;
    };
    if ty != QUAD {
        return (n.views)(instance, system, ty, capacity, count, out);
    }
    let blank = sys::ViewConfigurationView {
        ty: sys::ViewConfigurationView::TYPE,
        next: std::ptr::null_mut(),
        recommended_image_rect_width: 0,
        max_image_rect_width: 0,
        recommended_image_rect_height: 0,
        max_image_rect_height: 0,
        recommended_swapchain_sample_count: 0,
        max_swapchain_sample_count: 0,
    };
    let mut stereo = [blank; 2];
    let mut len = 0;
    let r = (n.views)(instance, system, STEREO, 2, &mut len, stereo.as_mut_ptr());
    if r.into_raw() < 0 {
        return r;
    }
    let focus = |v: sys::ViewConfigurationView| sys::ViewConfigurationView {
        recommended_image_rect_width: ((v.recommended_image_rect_width as f32 * FOCUS_TAN).ceil()
            as u32)
            .max(1),
        recommended_image_rect_height: ((v.recommended_image_rect_height as f32 * FOCUS_TAN).ceil()
            as u32)
            .max(1),
        ..v
    };
    // VERGENCE_QUAD_LAYER_CONTEXT_SCALE recommends the context views at
    // that fraction of the runtime's size, a lower density than the focus
    // views' (as Varjo's do).
    let scale: f32 = std::env::var("VERGENCE_QUAD_LAYER_CONTEXT_SCALE")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|s: &f32| *s > 0.0 && *s <= 1.0)
        .unwrap_or(1.0);
    let context = |v: sys::ViewConfigurationView| sys::ViewConfigurationView {
        recommended_image_rect_width: ((v.recommended_image_rect_width as f32 * scale).ceil()
            as u32)
            .max(1),
        recommended_image_rect_height: ((v.recommended_image_rect_height as f32 * scale).ceil()
            as u32)
            .max(1),
        ..v
    };
    let views = [
        context(stereo[0]),
        context(stereo[1]),
        focus(stereo[0]),
        focus(stereo[1]),
    ];
    fill_with(&views, capacity, count, out, |o, v| {
        *o = sys::ViewConfigurationView {
            ty: o.ty,
            next: o.next,
            ..*v
        }
    })
}

unsafe extern "system" fn enumerate_environment_blend_modes(
    instance: sys::Instance,
    system: sys::SystemId,
    ty: sys::ViewConfigurationType,
    capacity: u32,
    count: *mut u32,
    out: *mut sys::EnvironmentBlendMode,
) -> sys::Result {
    let Some(n) = next() else {
        return sys::Result::ERROR_HANDLE_INVALID;
    };
    let ty = if ty == QUAD { STEREO } else { ty };
    (n.blend)(instance, system, ty, capacity, count, out)
}

unsafe extern "system" fn begin_session(
    session: sys::Session,
    info: *const sys::SessionBeginInfo,
) -> sys::Result {
    let (Some(n), Some(info)) = (next(), info.as_ref()) else {
        return sys::Result::ERROR_HANDLE_INVALID;
    };
    let mut below = *info;
    if below.primary_view_configuration_type == QUAD {
        below.primary_view_configuration_type = STEREO;
        log("{\"begin\":\"foveated-inset\"}");
    }
    (n.begin)(session, &below)
}

/// The focus view of an eye's FOV: each tangent times [`FOCUS_TAN`].
fn focus_fov(f: sys::Fovf) -> sys::Fovf {
    let s = |a: f32| (a.tan() * FOCUS_TAN).atan();
    sys::Fovf {
        angle_left: s(f.angle_left),
        angle_right: s(f.angle_right),
        angle_up: s(f.angle_up),
        angle_down: s(f.angle_down),
    }
}

unsafe extern "system" fn locate_views(
    session: sys::Session,
    info: *const sys::ViewLocateInfo,
    state: *mut sys::ViewState,
    capacity: u32,
    count: *mut u32,
    out: *mut sys::View,
) -> sys::Result {
    let (Some(n), Some(info_ref)) = (next(), info.as_ref()) else {
        return sys::Result::ERROR_HANDLE_INVALID;
    };
    if info_ref.view_configuration_type != QUAD {
        return (n.locate)(session, info, state, capacity, count, out);
    }
    let mut below = *info_ref;
    below.view_configuration_type = STEREO;
    let blank = sys::View {
        ty: sys::View::TYPE,
        next: std::ptr::null_mut(),
        pose: sys::Posef::IDENTITY,
        fov: sys::Fovf::default(),
    };
    let mut eyes = [blank; 2];
    let mut len = 0;
    let r = if capacity == 0 {
        (n.locate)(session, &below, state, 0, &mut len, std::ptr::null_mut())
    } else {
        (n.locate)(session, &below, state, 2, &mut len, eyes.as_mut_ptr())
    };
    if r.into_raw() < 0 {
        return r;
    }
    let views = [
        eyes[0],
        eyes[1],
        sys::View {
            fov: focus_fov(eyes[0].fov),
            ..eyes[0]
        },
        sys::View {
            fov: focus_fov(eyes[1].fov),
            ..eyes[1]
        },
    ];
    fill_with(&views, capacity, count, out, |o, v| {
        o.pose = v.pose;
        o.fov = v.fov;
    })
}

unsafe extern "system" fn get_visibility_mask(
    session: sys::Session,
    ty: sys::ViewConfigurationType,
    index: u32,
    mask_type: sys::VisibilityMaskTypeKHR,
    mask: *mut sys::VisibilityMaskKHR,
) -> sys::Result {
    let Some(next_mask) = next().and_then(|n| n.mask) else {
        return sys::Result::ERROR_FUNCTION_UNSUPPORTED;
    };
    if ty != QUAD {
        return next_mask(session, ty, index, mask_type, mask);
    }
    if index < 2 {
        return next_mask(session, STEREO, index, mask_type, mask);
    }
    match mask.as_mut() {
        Some(m) => {
            m.vertex_count_output = 0;
            m.index_count_output = 0;
            sys::Result::SUCCESS
        }
        None => sys::Result::ERROR_VALIDATION_FAILURE,
    }
}

/// Whether `VERGENCE_QUAD_LAYER_LOG` names a log file.
fn logging() -> bool {
    std::env::var_os("VERGENCE_QUAD_LAYER_LOG").is_some()
}

/// Appends `line` to the file `VERGENCE_QUAD_LAYER_LOG` names.
fn log(line: &str) {
    let Some(path) = std::env::var_os("VERGENCE_QUAD_LAYER_LOG") else {
        return;
    };
    if let Ok(mut f) = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
    {
        let _ = writeln!(f, "{line}");
    }
}

/// One JSON line for a projection layer's views.
unsafe fn describe(p: &sys::CompositionLayerProjection) -> String {
    let views = if p.views.is_null() {
        &[][..]
    } else {
        std::slice::from_raw_parts(p.views, p.view_count as usize)
    };
    let fov: Vec<String> = views
        .iter()
        .map(|v| {
            format!(
                "[{},{},{},{}]",
                v.fov.angle_left, v.fov.angle_right, v.fov.angle_up, v.fov.angle_down
            )
        })
        .collect();
    let rect: Vec<String> = views
        .iter()
        .map(|v| {
            let r = v.sub_image.image_rect;
            format!(
                "[{},{},{},{},{}]",
                r.offset.x,
                r.offset.y,
                r.extent.width,
                r.extent.height,
                v.sub_image.image_array_index
            )
        })
        .collect();
    let mut chains: Vec<u64> = views
        .iter()
        .map(|v| v.sub_image.swapchain.into_raw())
        .collect();
    chains.sort_unstable();
    chains.dedup();
    format!(
        "{{\"views\":{},\"fov\":[{}],\"rect\":[{}],\"swapchains\":{}}}",
        p.view_count,
        fov.join(","),
        rect.join(","),
        chains.len()
    )
}

unsafe extern "system" fn end_frame(
    session: sys::Session,
    info: *const sys::FrameEndInfo,
) -> sys::Result {
    let (Some(n), Some(info_ref)) = (next(), info.as_ref()) else {
        return sys::Result::ERROR_HANDLE_INVALID;
    };
    let layers = if info_ref.layers.is_null() {
        &[][..]
    } else {
        std::slice::from_raw_parts(info_ref.layers, info_ref.layer_count as usize)
    };
    // Four-view projection layers go down as their context views.
    let mut stereo: Vec<sys::CompositionLayerProjection> = Vec::with_capacity(layers.len());
    let mut pointers: Vec<*const sys::CompositionLayerBaseHeader> =
        Vec::with_capacity(layers.len());
    for &l in layers {
        if !l.is_null() && (*l).ty == sys::CompositionLayerProjection::TYPE {
            let p = &*(l as *const sys::CompositionLayerProjection);
            if logging() {
                log(&describe(p));
            }
            if p.view_count == 4 {
                stereo.push(sys::CompositionLayerProjection {
                    view_count: 2,
                    ..*p
                });
                pointers.push(stereo.last().expect("pushed") as *const _ as *const _);
                continue;
            }
        }
        pointers.push(l);
    }
    let below = sys::FrameEndInfo {
        layers: pointers.as_ptr(),
        ..*info_ref
    };
    (n.end)(session, &below)
}
