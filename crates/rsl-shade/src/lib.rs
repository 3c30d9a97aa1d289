//! CPU frame shading with rotatable square lights and the multiple product approximation
//! (Xu et al. 2006, eq. 5 and fig. 8): a plain reference loop and a rayon fast path, the CPU
//! rasteriser that draws the shaded vertices, and display encoding.

pub mod antialias;
mod covers;
pub mod frame;
pub mod oracle;
pub mod pixel;
pub mod raster;
mod reference;
pub mod shade;
mod sum;
pub mod tonemap;
mod traced;

pub use oracle::{Blockers, OracleParams, OracleStats, Oracles, Rays, shade_oracle};
pub use pixel::{
    Covers, PIXEL_RAYS, PixelMesh, PixelPoint, draw_pixels, drawn_per_pixel, pixel_point, point_radiance,
    rasterise_antialiased, shade_covers, shade_covers_for, shade_image, traced_at_point,
};
pub use raster::{
    Fragment, Image, RasterMesh, background_image, fragments, rasterise, rasterise_changed, rasterise_over,
    sample_fragments,
};
pub use shade::{
    FrameSetup, FrameStats, Light, MaskedSums, OccluderBound, Pose, ShadeObject, TAIL_WIDTHS, Terms, Traced,
    TracedCovers, VertexFrames, density_tails, drawn_tail_cosines, shade, shade_objects, shade_objects_masked_and_not,
    shade_objects_untraced, shade_reference, tail_cosines,
};
