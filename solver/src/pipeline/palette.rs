//! The plots' colours, declared once for every plot the solver and the host tests draw: Okabe
//! and Ito's colour-blind-safe palette, and three greys. Blue and vermillion differ in hue and
//! lightness for every common colour-vision deficiency; yellow is far lighter than both; the
//! reddish purple of the exact boundary differs from all three.

use plotters::style::RGBColor;

/// Okabe-Ito blue: the safe set, braking, proven, certified.
pub const BLUE: RGBColor = RGBColor(0, 114, 178);
/// Okabe-Ito vermillion: accelerating, unproven for resolution, refused.
pub const VERMILLION: RGBColor = RGBColor(213, 94, 0);
/// Okabe-Ito yellow: a tie, either input.
pub const YELLOW: RGBColor = RGBColor(240, 228, 66);
/// Okabe-Ito reddish purple: the exact boundary, unproven for a collision.
pub const PURPLE: RGBColor = RGBColor(204, 121, 167);
/// Okabe-Ito bluish green: proven, a second curve.
pub const GREEN: RGBColor = RGBColor(0, 158, 115);
/// Okabe-Ito orange: a third curve, unproven for tangency, certified with exact sensors only.
pub const ORANGE: RGBColor = RGBColor(230, 159, 0);
/// Okabe-Ito sky blue: a fourth curve, proven at some ego speeds only.
pub const SKY_BLUE: RGBColor = RGBColor(86, 180, 233);
/// Light grey: in the constraint set, not safe (not certified).
pub const LIGHT_GREY: RGBColor = RGBColor(222, 222, 222);
/// Mid grey: a reference curve.
pub const MID_GREY: RGBColor = RGBColor(153, 153, 153);
/// Dark grey: outside the trusted box, where the solver's numbers carry no claim; not checked.
pub const DARK_GREY: RGBColor = RGBColor(140, 140, 140);
