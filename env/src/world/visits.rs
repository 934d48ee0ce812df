//! The visit heatmap: how often agents have stood on each cell.

use crate::map::Cell;

/// Per-cell visit counts (row-major over the grid), kept across episodes
/// until cleared: each episode's starts once, then every agent's cell after
/// every step.
#[derive(Debug, Clone)]
pub(super) struct VisitCounts {
    /// Columns of the grid.
    width: usize,
    /// Visits per cell.
    counts: Vec<u64>,
}

impl VisitCounts {
    /// No visits yet on a `height` × `width` grid.
    pub(super) fn new(height: usize, width: usize) -> Self {
        Self {
            width,
            counts: vec![0; height * width],
        }
    }

    /// Counts one visit of each of `cells` (cells of the grid).
    #[inline]
    pub(super) fn record(&mut self, cells: &[Cell]) {
        for cell in cells {
            self.counts[cell.row * self.width + cell.col] += 1;
        }
    }

    /// The counts, row-major.
    pub(super) fn counts(&self) -> &[u64] {
        &self.counts
    }

    /// Sets all counts to zero.
    pub(super) fn clear(&mut self) {
        self.counts.fill(0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_visits_row_major_until_cleared() {
        let mut v = VisitCounts::new(2, 3);
        v.record(&[Cell::new(0, 1), Cell::new(1, 2)]);
        v.record(&[Cell::new(0, 1)]);
        assert_eq!(v.counts(), &[0, 2, 0, 0, 0, 1]);
        v.clear();
        assert_eq!(v.counts(), &[0; 6]);
    }
}
