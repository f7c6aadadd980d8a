//! Unit conversions at the edges (the paper's Table 1 is in inches; FAA tables in pounds). Converted once.

/// Inch to metre (exact).
pub const IN_TO_M: f64 = 0.0254;
/// Pound-force to newton (exact by definition of the lbf).
pub const LBF_TO_N: f64 = 4.448_221_615_260_5;
/// Standard gravity, m/s².
pub const G0_M_S2: f64 = 9.806_65;
