//! The in-headset panel's image, drawn on lavapipe as the quad layer gets
//! it: each button in the colour of its state (the current tool and the
//! toggles that are on, off, or not allowed), the hovered button outlined,
//! the pointer dot where the ray meets the panel; zero validation messages.
//! (tests/xr_input.rs drives the panel through Monado: opening, pressing,
//! two composition layers.)

mod common;

use vergence::config::RenderConfig;
use vergence::interact::Tool;
use vergence::targets::panel::{
    centre_of, layout, Button, PanelState, PanelUi, DISABLED, HOVER, OFF, ON, POINTER, SIZE_PX,
};
use vergence::targets::toggles::Toggle;

fn near(px: &image::Rgba<u8>, want: egui::Color32, tol: i32) -> bool {
    let w = [want.r(), want.g(), want.b()];
    (0..3).all(|i| (px[i] as i32 - w[i] as i32).abs() <= tol) && px[3] == 255
}

/// A pixel inside `button`'s rectangle, 8 % in from its top-left corner
/// (clear of its centred label).
fn inside(button: Button) -> (u32, u32) {
    let r = layout()
        .into_iter()
        .find(|(b, _)| *b == button)
        .expect("laid out")
        .1;
    let u = r[0] + 0.08 * (r[2] - r[0]);
    let v = r[1] + 0.08 * (r[3] - r[1]);
    (
        (u * SIZE_PX[0] as f64) as u32,
        (v * SIZE_PX[1] as f64) as u32,
    )
}

#[test]
fn the_panel_shows_each_button_state_the_hover_and_the_pointer() {
    let ctx = common::context();
    let config = RenderConfig {
        effort: vergence::config::EffortConfig {
            stencil_mask: true,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    let allowed: Vec<Toggle> = Toggle::ALL
        .into_iter()
        .filter(|t| *t != Toggle::Msaa)
        .collect();
    let mut ui = PanelUi::new();
    let frame = ui.frame(&PanelState {
        tool: Tool::Measure,
        config: &config,
        allowed: &allowed,
        pointers: [None, centre_of(Button::Close)],
        times_ms: Some((4.2, 1.3, 11.1)),
        selected: Some("selected: pump-7 (pump, steel), 2.35 m away".into()),
    });
    let img = vergence::targets::xr_panel::snapshot(&ctx, &frame).expect("drawn");
    let out = common::scratch("panel", "image").join("panel.png");
    img.save(&out).expect("written");
    assert_eq!(img.dimensions(), (SIZE_PX[0], SIZE_PX[1]));
    let at = |b: Button| {
        let (x, y) = inside(b);
        *img.get_pixel(x, y)
    };
    let expect = [
        (Button::Tool(Tool::Measure), ON),
        (Button::Tool(Tool::Select), OFF),
        (Button::Tool(Tool::Section), OFF),
        (Button::Toggle(Toggle::StencilMask), ON),
        (Button::Toggle(Toggle::Stereo), ON),
        (Button::Toggle(Toggle::Rdm), OFF),
        (Button::Toggle(Toggle::Mffr), OFF),
        (Button::Toggle(Toggle::Msaa), DISABLED),
    ];
    for (b, colour) in expect {
        let px = at(b);
        assert!(
            near(&px, colour, 6),
            "{b:?}: {px:?} for {colour:?} ({})",
            out.display()
        );
    }
    // The hovered button's outline, at its left edge, half way down.
    let r = layout()
        .into_iter()
        .find(|(b, _)| *b == Button::Close)
        .expect("laid out")
        .1;
    let x = (r[0] * SIZE_PX[0] as f64) as u32 + 2;
    let y = ((r[1] + r[3]) * 0.5 * SIZE_PX[1] as f64) as u32;
    let px = *img.get_pixel(x, y);
    assert!(near(&px, HOVER, 6), "outline {px:?}");
    // No other button is outlined.
    let (x, y) = inside(Button::Tool(Tool::Select));
    let edge = *img.get_pixel((layout()[0].1[0] * SIZE_PX[0] as f64) as u32 + 2, y);
    assert!(
        !near(&edge, HOVER, 40),
        "select outlined: {edge:?} at {x},{y}"
    );
    // The pointer dot at the ray's point.
    let c = centre_of(Button::Close).unwrap();
    let px = *img.get_pixel(
        (c[0] * SIZE_PX[0] as f64) as u32,
        (c[1] * SIZE_PX[1] as f64) as u32,
    );
    assert!(near(&px, POINTER, 6), "pointer {px:?}");
    // Between the title and the tools: the translucent background.
    let px = *img.get_pixel(SIZE_PX[0] / 2, (0.19 * SIZE_PX[1] as f64) as u32);
    assert!(
        px[3] > 220 && px[3] < 245 && px[0] < 40,
        "background {px:?}"
    );
    // Labels: bright text pixels inside the select button.
    let r = layout()[0].1;
    let bright = (0..SIZE_PX[1])
        .flat_map(|y| (0..SIZE_PX[0]).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let (u, v) = (x as f64 / SIZE_PX[0] as f64, y as f64 / SIZE_PX[1] as f64);
            (r[0]..r[2]).contains(&u) && (r[1]..r[3]).contains(&v)
        })
        .filter(|&(x, y)| img.get_pixel(x, y)[0] > 200)
        .count();
    assert!(bright > 30, "{bright} text pixels in the select button");
    assert_eq!(ctx.validation_messages(), 0, "{:?}", ctx.validation_log());
}
