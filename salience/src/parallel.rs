//! The BSWDF split across a rayon thread pool (feature `rayon`): the same values as
//! [`crate::evaluate`], bit for bit, computed in independent chunks of nodes.

use rayon::prelude::*;

use crate::bswdf::{BswdfJob, Prepared};
use crate::error::SalienceError;
use crate::motion::GlobalMotion;

/// Nodes per task: large enough that scheduling costs vanish (a chunk is ~30 µs of work), small
/// enough that 100k nodes spread over a dozen cores.
pub const PARALLEL_CHUNK: usize = 4096;

/// As [`crate::evaluate`], with the nodes split into chunks of [`PARALLEL_CHUNK`] evaluated on
/// the current rayon pool. All checks run once before any thread starts; on error `out` is
/// untouched. The result is identical to the single-threaded one (each node's value depends only
/// on its own inputs).
pub fn evaluate_parallel(
    job: &BswdfJob<'_>,
    out: &mut [f32],
) -> Result<GlobalMotion, SalienceError> {
    let n = job.nodes.positions.len();
    if out.len() != n {
        return Err(SalienceError::LengthMismatch {
            what: "out",
            expected: n,
            found: out.len(),
        });
    }
    let prepared = Prepared::new(job, 0, n)?;
    out.par_chunks_mut(PARALLEL_CHUNK)
        .enumerate()
        .for_each(|(chunk, part)| {
            prepared.run(job, chunk * PARALLEL_CHUNK, part);
        });
    Ok(prepared.global)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BswdfParams, NeighbourLists, Nodes, ObjectMotion, View, evaluate};
    use glam::Vec3;

    #[test]
    fn parallel_equals_serial_and_refuses_cleanly() {
        let n = 3 * PARALLEL_CHUNK + 17;
        let positions: Vec<Vec3> = (0..n)
            .map(|i| Vec3::new((i % 100) as f32 * 0.01, (i / 100) as f32 * 0.01, 0.0))
            .collect();
        let velocities: Vec<Vec3> = (0..n)
            .map(|i| Vec3::new(0.0, 0.0, ((i * 7919) % 13) as f32 * 0.1))
            .collect();
        let edges: Vec<[u32; 2]> = (1..n as u32).map(|i| [i - 1, i]).collect();
        let lists = NeighbourLists::from_undirected_edges(n, &edges).unwrap();
        let view =
            View::look_at(Vec3::new(0.5, 0.5, 2.0), Vec3::ZERO, Vec3::Y, 1.0, 800, 600).unwrap();
        let params = BswdfParams::default();
        let job = BswdfJob {
            view: &view,
            object: ObjectMotion::mean_of(&positions, &velocities).unwrap(),
            params: &params,
            nodes: Nodes {
                positions: &positions,
                velocities: &velocities,
                normals: None,
            },
            neighbours: lists.as_neighbours(),
        };
        let mut serial = vec![0.0; n];
        let mut parallel = vec![0.0; n];
        evaluate(&job, &mut serial).unwrap();
        evaluate_parallel(&job, &mut parallel).unwrap();
        assert_eq!(serial, parallel);
        assert!(serial.iter().any(|&s| s > 0.1));
        let mut short = vec![-1.0; n - 1];
        assert!(evaluate_parallel(&job, &mut short).is_err());
        assert!(short.iter().all(|&s| s == -1.0));
    }
}
