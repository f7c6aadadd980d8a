//! Lookup tables with linear interpolation, clamped at the ends (JSBSim's `<table>` semantics: outside
//! the breakpoints the end value holds): [`Table1`] `y(x)` and [`Table2`] `z(row, column)`.

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

/// Strictly increasing, finite breakpoints (at least one).
fn check_breakpoints(x: &[f64]) -> Result<(), String> {
    if x.is_empty() {
        return Err("a table needs at least one breakpoint".into());
    }
    for (k, v) in x.iter().enumerate() {
        if !v.is_finite() {
            return Err(format!("breakpoint {} is not finite", k + 1));
        }
        if k > 0 && *v <= x[k - 1] {
            return Err(format!(
                "breakpoints must increase strictly: breakpoint {} = {v} after {}",
                k + 1,
                x[k - 1]
            ));
        }
    }
    Ok(())
}

/// The segment of `x` holding `v` and the weight of its upper end, clamped to the ends.
fn locate(x: &[f64], v: f64) -> (usize, f64) {
    let n = x.len();
    if n == 1 || v <= x[0] {
        return (0, 0.0);
    }
    if v >= x[n - 1] {
        return (n - 2, 1.0);
    }
    let k = x.partition_point(|&b| b <= v);
    (k - 1, (v - x[k - 1]) / (x[k] - x[k - 1]))
}

/// `z(r, c)` by bilinear interpolation over row and column breakpoints, held beyond the ends (JSBSim's
/// two-dimensional `<table>` with `lookup="row"` and `lookup="column"`).
#[derive(Debug, Clone, PartialEq)]
pub struct Table2 {
    rows: Vec<f64>,
    columns: Vec<f64>,
    /// Row-major values, `rows.len() × columns.len()`.
    z: Vec<f64>,
}

impl Table2 {
    /// A table from its row and column breakpoints (finite, strictly increasing) and one row of values
    /// per row breakpoint, each with one value per column breakpoint.
    pub fn new(rows: &[f64], columns: &[f64], values: &[Vec<f64>]) -> Result<Self, String> {
        check_breakpoints(rows).map_err(|e| format!("row {e}"))?;
        check_breakpoints(columns).map_err(|e| format!("column {e}"))?;
        if values.len() != rows.len() {
            return Err(format!(
                "{} rows of values for {} row breakpoints",
                values.len(),
                rows.len()
            ));
        }
        for (k, r) in values.iter().enumerate() {
            if r.len() != columns.len() {
                return Err(format!(
                    "row {} has {} values for {} column breakpoints",
                    k + 1,
                    r.len(),
                    columns.len()
                ));
            }
            if r.iter().any(|v| !v.is_finite()) {
                return Err(format!("row {} has a non-finite value", k + 1));
            }
        }
        Ok(Self {
            rows: rows.to_vec(),
            columns: columns.to_vec(),
            z: values.concat(),
        })
    }

    /// The value at `(r, c)`.
    pub fn eval(&self, r: f64, c: f64) -> f64 {
        let nc = self.columns.len();
        let (i, wr) = locate(&self.rows, r);
        let (j, wc) = locate(&self.columns, c);
        let at = |i: usize, j: usize| self.z[i.min(self.rows.len() - 1) * nc + j.min(nc - 1)];
        let lo = at(i, j) + wc * (at(i, j + 1) - at(i, j));
        let hi = at(i + 1, j) + wc * (at(i + 1, j + 1) - at(i + 1, j));
        lo + wr * (hi - lo)
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

    /// Bilinear inside (exact on a plane), the edge values held outside, and the corner values returned
    /// at the corners.
    #[test]
    fn two_dimensional_tables_are_bilinear_inside_and_held_outside() {
        let plane = |r: f64, c: f64| 1.0 + 2.0 * r - 3.0 * c;
        let (rows, cols) = ([0.0, 1.0, 3.0], [-1.0, 0.5]);
        let values: Vec<Vec<f64>> = rows
            .iter()
            .map(|&r| cols.iter().map(|&c| plane(r, c)).collect())
            .collect();
        let t = Table2::new(&rows, &cols, &values).unwrap();
        for (r, c) in [(0.3, -0.2), (2.0, 0.1), (1.0, -1.0), (3.0, 0.5)] {
            assert!((t.eval(r, c) - plane(r, c)).abs() < 1e-12, "{r} {c}");
        }
        assert!((t.eval(-5.0, 9.0) - plane(0.0, 0.5)).abs() < 1e-12);
        assert!((t.eval(7.0, -4.0) - plane(3.0, -1.0)).abs() < 1e-12);
        // a saddle is not a plane: the centre of a cell is the mean of its corners
        let s = Table2::new(&[0.0, 1.0], &[0.0, 1.0], &[vec![0.0, 1.0], vec![1.0, 0.0]]).unwrap();
        assert!((s.eval(0.5, 0.5) - 0.5).abs() < 1e-12);
        assert!(Table2::new(&[0.0, 1.0], &[0.0], &[vec![1.0]]).is_err());
        assert!(Table2::new(&[0.0], &[0.0, 0.0], &[vec![1.0, 2.0]]).is_err());
    }

    #[test]
    fn rejects_non_increasing_breakpoints() {
        assert!(Table1::new(&[[0.0, 1.0], [0.0, 2.0]]).is_err());
        assert!(Table1::new(&[]).is_err());
    }
}
