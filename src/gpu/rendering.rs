//! Dynamic-rendering scopes of one colour attachment: the window's mask
//! clears, the overlay and panel, the distortion preview, the colour-only
//! passes. One place says how such a scope starts, so the load/store and
//! layout choices do not drift between them.

use ash::vk;

/// What a scope does with the attachment's contents when it begins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Load {
    /// Keep them (drawn over).
    Keep,
    /// Clear to this linear RGBA.
    Clear([f32; 4]),
    /// Undefined: every pixel the scope needs is written.
    Discard,
}

/// Begins a rendering scope over `extent` (from the origin) with the one
/// colour attachment `view` in COLOR_ATTACHMENT_OPTIMAL, started as `load`
/// says and stored, for the views of `view_mask` (0: one view).
///
/// # Safety
/// `cmd` is recording outside any rendering scope on `device`, and `view`
/// is a colour view of an image in COLOR_ATTACHMENT_OPTIMAL whose earlier
/// writes the caller has made visible to colour-attachment access.
pub unsafe fn begin_color(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    view: vk::ImageView,
    extent: vk::Extent2D,
    load: Load,
    view_mask: u32,
) {
    let (op, clear) = match load {
        Load::Keep => (vk::AttachmentLoadOp::LOAD, [0.0; 4]),
        Load::Clear(c) => (vk::AttachmentLoadOp::CLEAR, c),
        Load::Discard => (vk::AttachmentLoadOp::DONT_CARE, [0.0; 4]),
    };
    let attachments = [vk::RenderingAttachmentInfo::default()
        .image_view(view)
        .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        .load_op(op)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue {
            color: vk::ClearColorValue { float32: clear },
        })];
    let info = vk::RenderingInfo::default()
        .render_area(vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent,
        })
        .layer_count(1)
        .view_mask(view_mask)
        .color_attachments(&attachments);
    // SAFETY: the caller's contract (above).
    unsafe { device.cmd_begin_rendering(cmd, &info) };
}
