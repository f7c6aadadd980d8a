//! One-dimensional lookup tables with linear interpolation, clamped at the ends (JSBSim's
//! `<table>` semantics: outside the breakpoints the end value holds).

/// `y(x)` by linear interpolation between strictly increasing breakpoints.
#[derive(Debug, Clone, PartialEq)]
pub struct Table1 {
    x: Vec<f64>,
    y: Vec<f64>,
}

impl Table1 {
    /// A table from `[x, y]` rows; `x` must be finite and strictly increasing, at least one row.
    pub fn new(rows: &[[f64; 2]]) -> Result<Self, String> {
        if rows.is_empty() {
            return Err("a table needs at least one [x, y] row".into());
        }
        for (k, r) in rows.iter().enumerate() {
            if !r[0].is_finite() || !r[1].is_finite() {
                return Err(format!("row {} has a non-finite value", k + 1));
            }
            if k > 0 && r[0] <= rows[k - 1][0] {
                return Err(format!(
                    "breakpoints must increase strictly: row {} x = {} after {}",
                    k + 1,
                    r[0],
                    rows[k - 1][0]
                ));
            }
        }
        Ok(Self {
            x: rows.iter().map(|r| r[0]).collect(),
            y: rows.iter().map(|r| r[1]).collect(),
        })
    }

    /// A constant table.
    pub fn constant(y: f64) -> Self {
        Self {
            x: vec![0.0],
            y: vec![y],
        }
    }

    /// The value at `x`, linear between breakpoints and held beyond the ends.
    pub fn eval(&self, x: f64) -> f64 {
        let n = self.x.len();
        if n == 1 || x <= self.x[0] {
            return self.y[0];
        }
        if x >= self.x[n - 1] {
            return self.y[n - 1];
        }
        // first breakpoint above x
        let k = self.x.partition_point(|&b| b <= x);
        let (x0, x1, y0, y1) = (self.x[k - 1], self.x[k], self.y[k - 1], self.y[k]);
        y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    }

    /// Slope dy/dx of the segment containing `x` (zero outside the table).
    pub fn slope(&self, x: f64) -> f64 {
        let n = self.x.len();
        if n == 1 || x < self.x[0] || x > self.x[n - 1] {
            return 0.0;
        }
        let k = self.x.partition_point(|&b| b <= x).clamp(1, n - 1);
        (self.y[k] - self.y[k - 1]) / (self.x[k] - self.x[k - 1])
    }

    /// Largest tabulated value.
    pub fn max_value(&self) -> f64 {
        self.y.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    /// The first and last breakpoint.
    pub fn x_range(&self) -> (f64, f64) {
        (self.x[0], self.x[self.x.len() - 1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_linearly_and_holds_end_values() {
        let t = Table1::new(&[[0.0, 1.0], [1.0, 3.0], [3.0, 3.0]]).unwrap();
        assert_eq!(t.eval(0.5), 2.0);
        assert_eq!(t.eval(-1.0), 1.0);
        assert_eq!(t.eval(10.0), 3.0);
        assert_eq!(t.slope(0.25), 2.0);
        assert_eq!(t.slope(2.0), 0.0);
    }

    #[test]
    fn rejects_non_increasing_breakpoints() {
        assert!(Table1::new(&[[0.0, 1.0], [0.0, 2.0]]).is_err());
        assert!(Table1::new(&[]).is_err());
    }
}
