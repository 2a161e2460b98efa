//! PNG pictures: the figure's own SVG rasterised with resvg, so that a PNG shows exactly what
//! the SVG shows, text shaped and anti-aliased from the embedded DejaVu Sans.
//!
//! The font database holds only the embedded regular and bold faces (never a system font),
//! and the generic family [`super::canvas::FONT`] — the only one the figures name — maps to them: the
//! pixels do not depend on the machine. Images referenced by the SVG are never loaded (the
//! figures have none), so rendering reads no file.

use std::sync::{Arc, OnceLock};

use resvg::tiny_skia::{Color, Pixmap, Transform};
use resvg::usvg::{fontdb, ImageHrefResolver, Options, Tree};

use crate::error::{Error, Result};

/// The family name inside the embedded font files.
const DEJAVU_SANS: &str = "DejaVu Sans";

/// The font database: the embedded DejaVu Sans regular and bold, the generic families mapped
/// to it (`serif` too: usvg falls back to it for a family it does not find, so any text is
/// drawn in DejaVu Sans); built once.
///
/// # Errors
/// The embedded fonts did not load as two faces of DejaVu Sans (a broken build).
fn fonts() -> Result<Arc<fontdb::Database>> {
    static FONTS: OnceLock<Option<Arc<fontdb::Database>>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            let mut fonts = fontdb::Database::new();
            fonts.load_font_data(dejavu::sans::regular().to_vec());
            fonts.load_font_data(dejavu::sans::bold().to_vec());
            let dejavu_only = fonts.len() == 2
                && fonts
                    .faces()
                    .all(|face| face.families.iter().any(|(name, _)| name == DEJAVU_SANS));
            fonts.set_sans_serif_family(DEJAVU_SANS);
            fonts.set_serif_family(DEJAVU_SANS);
            fonts.set_monospace_family(DEJAVU_SANS);
            dejavu_only.then(|| Arc::new(fonts))
        })
        .clone()
        .ok_or_else(|| {
            Error::Invalid("the embedded DejaVu Sans font could not be loaded for PNG text".into())
        })
}

/// How the SVG is read: the embedded fonts only, DejaVu Sans by default, no image loaded.
fn options() -> Result<Options<'static>> {
    Ok(Options {
        font_family: DEJAVU_SANS.into(),
        fontdb: fonts()?,
        image_href_resolver: ImageHrefResolver {
            resolve_data: Box::new(|_, _, _| None),
            resolve_string: Box::new(|_, _| None),
        },
        ..Options::default()
    })
}

/// The PNG file of `svg` drawn on `width × height` pixels over white, one pixel a user unit
/// of the SVG (whose size the figure sets to the same numbers).
///
/// # Errors
/// The SVG cannot be read (it came from plotters: a bug), the size is empty or too large
/// for a picture in memory, or the PNG cannot be encoded; each named as such.
pub(super) fn svg_to_png(svg: &str, width: u32, height: u32) -> Result<Vec<u8>> {
    let failed = |what: String| Error::Invalid(format!("cannot draw the PNG picture: {what}"));
    let tree = Tree::from_str(svg, &options()?)
        .map_err(|e| failed(format!("its SVG cannot be read: {e}")))?;
    let mut pixmap = Pixmap::new(width, height)
        .ok_or_else(|| failed(format!("no image of {width} × {height} pixels")))?;
    pixmap.fill(Color::WHITE);
    let size = tree.size();
    let scale = Transform::from_scale(
        width as f32 / size.width().max(1.0),
        height as f32 / size.height().max(1.0),
    );
    resvg::render(&tree, scale, &mut pixmap.as_mut());
    pixmap
        .encode_png()
        .map_err(|e| failed(format!("the PNG encoder failed: {e}")))
}
