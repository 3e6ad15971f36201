//! Neighbour lists in compressed-sparse-row form: node `i`'s neighbours are
//! `indices[offsets[i]..offsets[i + 1]]`, indices into the per-node slices.
//!
//! [`Neighbours`] is a borrowed view validated once when it is built (O(entries)), so that
//! evaluations, which may run every few steps on an unchanged topology, only check that the
//! node count matches. [`NeighbourLists`] owns the two arrays and builds them from an edge list
//! (for a mass-spring system: its links), reusing its buffers on rebuild.

use crate::error::SalienceError;

/// A validated CSR neighbour table over `node_count` nodes.
#[derive(Debug, Clone, Copy)]
pub struct Neighbours<'a> {
    offsets: &'a [u32],
    indices: &'a [u32],
}

impl<'a> Neighbours<'a> {
    /// Validates and wraps a CSR table: `offsets` has `node_count + 1` entries, starts at 0,
    /// never decreases and ends at `indices.len()`; every index is `< node_count`.
    /// A node may list itself or a neighbour twice; both just weight that entry in the mean.
    pub fn new(
        offsets: &'a [u32],
        indices: &'a [u32],
        node_count: usize,
    ) -> Result<Self, SalienceError> {
        if offsets.len() != node_count + 1 {
            return Err(SalienceError::OffsetsLength {
                expected: node_count + 1,
                found: offsets.len(),
            });
        }
        if node_count > u32::MAX as usize {
            return Err(SalienceError::TooManyEntries { count: node_count });
        }
        if offsets[0] != 0 {
            return Err(SalienceError::OffsetsNotMonotone { node: 0 });
        }
        if let Some(node) = offsets.windows(2).position(|w| w[1] < w[0]) {
            return Err(SalienceError::OffsetsNotMonotone { node });
        }
        if offsets[node_count] as usize != indices.len() {
            return Err(SalienceError::OffsetsNotMonotone { node: node_count });
        }
        // One branch-free pass for the common (valid) case; locate the culprit only on failure.
        let max = indices.iter().copied().max().unwrap_or(0);
        if !indices.is_empty() && max as usize >= node_count {
            let at = indices
                .iter()
                .position(|&j| j as usize >= node_count)
                .unwrap_or(0);
            let node = offsets[1..].partition_point(|&o| o as usize <= at);
            return Err(SalienceError::NeighbourOutOfRange {
                node,
                neighbour: indices[at],
                node_count,
            });
        }
        Ok(Self { offsets, indices })
    }

    /// Number of nodes the table covers.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.offsets.len() - 1
    }

    /// The row table (`node_count + 1` entries).
    #[inline]
    pub fn offsets(&self) -> &'a [u32] {
        self.offsets
    }

    /// All neighbour indices, row after row.
    #[inline]
    pub fn indices(&self) -> &'a [u32] {
        self.indices
    }

    /// The neighbours of `node`.
    ///
    /// # Panics
    /// If `node >= node_count()`.
    #[inline]
    pub fn of(&self, node: usize) -> &'a [u32] {
        &self.indices[self.offsets[node] as usize..self.offsets[node + 1] as usize]
    }
}

/// Owned CSR neighbour lists, built from undirected edges.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NeighbourLists {
    offsets: Vec<u32>,
    indices: Vec<u32>,
}

impl NeighbourLists {
    /// Builds the lists of `node_count` nodes from undirected edges `(a, b)`: each edge makes
    /// `a` a neighbour of `b` and `b` of `a`. Self-edges are dropped and repeated edges kept
    /// once; each row is sorted, so the result depends only on the set of edges.
    pub fn from_undirected_edges(
        node_count: usize,
        edges: &[[u32; 2]],
    ) -> Result<Self, SalienceError> {
        let mut lists = Self::default();
        lists.rebuild_from_undirected_edges(node_count, edges)?;
        Ok(lists)
    }

    /// As [`NeighbourLists::from_undirected_edges`], reusing this value's buffers (no allocation
    /// once they are large enough). On error `self` is unchanged.
    pub fn rebuild_from_undirected_edges(
        &mut self,
        node_count: usize,
        edges: &[[u32; 2]],
    ) -> Result<(), SalienceError> {
        self.rebuild_from_edge_iter(node_count, edges.iter().copied())
    }

    /// As [`NeighbourLists::rebuild_from_undirected_edges`], reading the edges from an iterator
    /// (walked three times: check, count, scatter), so a caller can feed its own link records
    /// without copying them into an edge array first, e.g.
    /// `lists.rebuild_from_edge_iter(n, links.iter().map(|l| [l.a, l.b]))`.
    pub fn rebuild_from_edge_iter<I>(
        &mut self,
        node_count: usize,
        edges: I,
    ) -> Result<(), SalienceError>
    where
        I: Iterator<Item = [u32; 2]> + Clone,
    {
        if node_count >= u32::MAX as usize {
            return Err(SalienceError::TooManyEntries { count: node_count });
        }
        let mut edge_count = 0usize;
        for e in edges.clone() {
            if e[0].max(e[1]) as usize >= node_count {
                let (node, neighbour) = if e[0] as usize >= node_count {
                    (e[1] as usize, e[0])
                } else {
                    (e[0] as usize, e[1])
                };
                return Err(SalienceError::NeighbourOutOfRange {
                    node,
                    neighbour,
                    node_count,
                });
            }
            edge_count += 1;
        }
        if edge_count > (u32::MAX / 2) as usize {
            return Err(SalienceError::TooManyEntries {
                count: edge_count * 2,
            });
        }
        // Counting sort: degree per node, prefix sums, scatter.
        self.offsets.clear();
        self.offsets.resize(node_count + 1, 0);
        for [a, b] in edges.clone() {
            if a != b {
                self.offsets[a as usize + 1] += 1;
                self.offsets[b as usize + 1] += 1;
            }
        }
        for i in 0..node_count {
            self.offsets[i + 1] += self.offsets[i];
        }
        let total = self.offsets[node_count] as usize;
        self.indices.clear();
        self.indices.resize(total, 0);
        // Scatter with a running cursor per node, kept in the offsets shifted by one slot.
        for [a, b] in edges {
            if a != b {
                let ca = &mut self.offsets[a as usize];
                self.indices[*ca as usize] = b;
                *ca += 1;
                let cb = &mut self.offsets[b as usize];
                self.indices[*cb as usize] = a;
                *cb += 1;
            }
        }
        // Each cursor now sits at its row's end = the next row's start; shift back.
        for i in (1..=node_count).rev() {
            self.offsets[i] = self.offsets[i - 1];
        }
        self.offsets[0] = 0;
        // Sort and deduplicate each row, compacting in place.
        let mut write = 0usize;
        let mut start = 0usize;
        for i in 0..node_count {
            let end = self.offsets[i + 1] as usize;
            self.indices[start..end].sort_unstable();
            let row_begin = write;
            for k in start..end {
                let j = self.indices[k];
                if write == row_begin || self.indices[write - 1] != j {
                    self.indices[write] = j;
                    write += 1;
                }
            }
            start = end;
            self.offsets[i + 1] = write as u32;
        }
        self.indices.truncate(write);
        Ok(())
    }

    /// The validated view used by the evaluators.
    pub fn as_neighbours(&self) -> Neighbours<'_> {
        if self.offsets.is_empty() {
            // An empty table over zero nodes.
            return Neighbours {
                offsets: &[0],
                indices: &[],
            };
        }
        Neighbours {
            offsets: &self.offsets,
            indices: &self.indices,
        }
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_catches_each_defect() {
        assert!(Neighbours::new(&[0, 1, 2], &[1, 0], 2).is_ok());
        assert!(matches!(
            Neighbours::new(&[0, 1], &[1, 0], 2),
            Err(SalienceError::OffsetsLength { .. })
        ));
        assert!(matches!(
            Neighbours::new(&[1, 1, 2], &[1, 0], 2),
            Err(SalienceError::OffsetsNotMonotone { node: 0 })
        ));
        assert!(matches!(
            Neighbours::new(&[0, 2, 1, 2], &[1, 0], 3),
            Err(SalienceError::OffsetsNotMonotone { node: 1 })
        ));
        assert!(matches!(
            Neighbours::new(&[0, 1, 1], &[1, 0], 2),
            Err(SalienceError::OffsetsNotMonotone { node: 2 })
        ));
        assert_eq!(
            Neighbours::new(&[0, 1, 3], &[1, 0, 7], 2).unwrap_err(),
            SalienceError::NeighbourOutOfRange {
                node: 1,
                neighbour: 7,
                node_count: 2
            }
        );
        assert_eq!(Neighbours::new(&[0], &[], 0).unwrap().node_count(), 0);
    }

    #[test]
    fn edges_build_sorted_deduplicated_symmetric_rows() {
        let edges = [[0, 1], [1, 2], [2, 0], [1, 0], [3, 3], [2, 3]];
        let lists = NeighbourLists::from_undirected_edges(5, &edges).unwrap();
        let n = lists.as_neighbours();
        assert_eq!(n.node_count(), 5);
        assert_eq!(n.of(0), &[1, 2]);
        assert_eq!(n.of(1), &[0, 2]);
        assert_eq!(n.of(2), &[0, 1, 3]);
        assert_eq!(n.of(3), &[2]);
        assert_eq!(n.of(4), &[] as &[u32]);
        // The view it hands out passes full validation.
        Neighbours::new(n.offsets(), n.indices(), 5).unwrap();
    }

    #[test]
    fn rebuild_reuses_and_refuses_cleanly() {
        let mut lists = NeighbourLists::from_undirected_edges(3, &[[0, 1], [1, 2]]).unwrap();
        let before = lists.clone();
        assert!(lists.rebuild_from_undirected_edges(3, &[[0, 5]]).is_err());
        assert_eq!(lists, before, "unchanged on error");
        lists.rebuild_from_undirected_edges(2, &[[1, 0]]).unwrap();
        assert_eq!(lists.as_neighbours().of(0), &[1]);
        // The iterator form builds the same lists as the slice form.
        let edges = [[0u32, 3], [3, 1], [1, 0], [2, 2]];
        let from_slice = NeighbourLists::from_undirected_edges(4, &edges).unwrap();
        lists
            .rebuild_from_edge_iter(4, edges.iter().map(|e| [e[1], e[0]]))
            .unwrap();
        assert_eq!(lists, from_slice);
        assert_eq!(NeighbourLists::default().as_neighbours().node_count(), 0);
    }
}
