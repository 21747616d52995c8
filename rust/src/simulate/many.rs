//! Echoes of many scenes in one parallel call, each scene with poses of its own: the pulses of
//! a batch of environments, each in its own forest. Every scene's echoes are those of
//! [`simulate`] for it alone, bit for bit, for any number of threads.

use super::{simulate, Echoes, Method};
use crate::error::{Error, Result};
use crate::fast::FastSonar;
use crate::interrupt::Interrupt;
use crate::lobe::Search;
use crate::physics::pose::Pose;
use crate::scene::Scene;
use rayon::prelude::*;

/// The echoes of each `(scene, poses)` job by one `sonar`, jobs (and, within each, poses) in
/// parallel; each pose looks at `stop` first. An error names the first failing job in order
/// (an interrupt is said as it is).
pub fn simulate_many(
    jobs: &[(&Scene, &[Pose])],
    sonar: &FastSonar,
    with_impulse: bool,
    search: Search,
    method: Method,
    stop: &Interrupt,
) -> Result<Vec<Echoes>> {
    if rayon::current_thread_index().is_none() {
        // From outside the pool: run on a pool thread, as `simulate` does.
        return rayon::scope(|_| simulate_many(jobs, sonar, with_impulse, search, method, stop));
    }
    let out: Vec<Result<Echoes>> = jobs
        .par_iter()
        .map(|&(scene, poses)| simulate(scene, sonar, poses, with_impulse, search, method, stop))
        .collect();
    out.into_iter()
        .enumerate()
        .map(|(j, r)| r.map_err(|e| in_job(j, e)))
        .collect()
}

/// `e` with the job it came from named in its message.
fn in_job(j: usize, e: Error) -> Error {
    match e {
        Error::InvalidInput(m) => Error::InvalidInput(format!("scene {j}: {m}")),
        Error::TooLarge(m) => Error::TooLarge(format!("scene {j}: {m}")),
        Error::Interrupted => Error::Interrupted,
        other => Error::InvalidInput(format!("scene {j}: {other}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interrupt::NEVER;
    use crate::test_util::sonar_with;

    fn scene(shift: f64) -> Scene {
        let centers: Vec<[f64; 3]> = (0..40)
            .map(|i| {
                [
                    2.0 + 0.1 * i as f64,
                    shift + 0.05 * (i % 7) as f64,
                    0.02 * (i % 5) as f64,
                ]
            })
            .collect();
        let normals = vec![[-1.0, 0.0, 0.0]; centers.len()];
        let radii = vec![0.02; centers.len()];
        Scene::new(centers, normals, radii).expect("a valid scene")
    }

    #[test]
    fn each_scene_gets_the_echoes_simulate_gives_it_alone() {
        let sonar = sonar_with(|_| {});
        let poses = [Pose::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).expect("a frame")];
        let (a, b) = (scene(0.0), scene(0.3));
        let jobs: [(&Scene, &[Pose]); 2] = [(&a, &poses), (&b, &poses)];
        let many =
            simulate_many(&jobs, &sonar, true, Search::Bvh, Method::Exact, &NEVER).expect("ok");
        for (sc, got) in [&a, &b].into_iter().zip(&many) {
            let one =
                simulate(sc, &sonar, &poses, true, Search::Bvh, Method::Exact, &NEVER).expect("ok");
            assert_eq!(got.spectrum_re, one.spectrum_re);
            assert_eq!(got.spectrum_im, one.spectrum_im);
            assert_eq!(got.impulse, one.impulse);
            assert_eq!(got.n_leaves, one.n_leaves);
        }
    }

    #[test]
    fn a_raised_interrupt_stops_every_path_with_interrupted_unnamed_by_scene() {
        use crate::interrupt::Interrupt;
        use crate::sonar::Receiver;
        let stop = Interrupt::new();
        stop.raise();
        let poses = [Pose::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).expect("a frame")];
        let sc = scene(0.0);
        let one_ear = sonar_with(|_| {});
        let ears = sonar_with(|p| p.receivers = vec![Receiver::at_emitter(); 2]);
        for sonar in [&one_ear, &ears] {
            let got = simulate(&sc, sonar, &poses, true, Search::Bvh, Method::Exact, &stop);
            assert_eq!(got.err(), Some(Error::Interrupted));
            let jobs: [(&Scene, &[Pose]); 1] = [(&sc, &poses)];
            let many = simulate_many(&jobs, sonar, false, Search::Bvh, Method::Exact, &stop);
            assert_eq!(many.err(), Some(Error::Interrupted));
        }
    }
}
