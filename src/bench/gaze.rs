//! The gaze a bench run follows (`gaze`, `gaze_latency_ms` in a plan): the
//! foveated techniques' centre follows the gaze as an eye tracker reported
//! it `gaze_latency_ms` earlier, and the foveated error is measured where
//! the eye truly looks on that frame.

use super::plan::{GazeKind, Plan};
use crate::view::gaze_path::{ndc, GazePath};
use crate::view::Fov;

/// A moving gaze along a bench run's frames.
pub struct BenchGaze {
    path: GazePath,
    latency_s: f64,
    frame_s: f64,
    fovs: [Fov; 2],
}

impl BenchGaze {
    /// The plan's gaze for a path of `frames` frames at `refresh_hz` seen
    /// through `fovs`; None for `centre` (the techniques keep their own
    /// centre and the error is measured at the image centre).
    pub fn new(plan: &Plan, fovs: [Fov; 2], frames: usize, refresh_hz: f64) -> Option<BenchGaze> {
        match plan.gaze {
            GazeKind::Centre => None,
            GazeKind::Saccades => {
                let frame_s = 1.0 / refresh_hz.max(1.0);
                // Its own seed, derived from the head path's.
                let seed = plan.path_seed ^ 0x6761_7a65;
                Some(BenchGaze {
                    path: GazePath::saccades(seed, frames as f64 * frame_s + 1.0),
                    latency_s: plan.gaze_latency_ms / 1000.0,
                    frame_s,
                    fovs,
                })
            }
        }
    }

    /// Where the eye truly looks on frame `frame` in eye `eye`'s image, NDC.
    pub fn true_ndc(&self, frame: usize, eye: usize) -> [f64; 2] {
        ndc(
            &self.fovs[eye % 2],
            self.path.at(frame as f64 * self.frame_s),
        )
    }

    /// The gaze the techniques follow on frame `frame`: the tracker's
    /// report from `gaze_latency_ms` earlier, as one NDC point for both
    /// eyes (their mean; the inset and the foveation centre share one).
    pub fn reported_ndc(&self, frame: usize) -> [f32; 2] {
        let dir = self.path.at(frame as f64 * self.frame_s - self.latency_s);
        let [l, r] = [0, 1].map(|eye| ndc(&self.fovs[eye], dir));
        [((l[0] + r[0]) / 2.0) as f32, ((l[1] + r[1]) / 2.0) as f32]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(latency_ms: f64) -> Plan {
        let mut p = Plan::resolve("smoke").unwrap();
        p.gaze = GazeKind::Saccades;
        p.gaze_latency_ms = latency_ms;
        p
    }

    #[test]
    fn the_reported_gaze_lags_the_true_one_by_the_latency() {
        let fov = Fov::symmetric(0.8, 0.8);
        // 50 ms at 100 Hz: five frames.
        let g = BenchGaze::new(&plan(50.0), [fov, fov], 400, 100.0).unwrap();
        let mut moved = 0;
        for i in 5..400 {
            let reported = g.reported_ndc(i);
            let truth = g.true_ndc(i - 5, 0);
            assert!((reported[0] as f64 - truth[0]).abs() < 1e-5);
            assert!((reported[1] as f64 - truth[1]).abs() < 1e-5);
            if g.true_ndc(i, 0) != truth {
                moved += 1;
            }
        }
        // Saccades happen, so the lag shows on some frames.
        assert!(moved > 10, "{moved}");
        let instant = BenchGaze::new(&plan(0.0), [fov, fov], 400, 100.0).unwrap();
        let r = instant.reported_ndc(123);
        let t = instant.true_ndc(123, 1);
        assert!((r[0] as f64 - t[0]).abs() < 1e-6 && (r[1] as f64 - t[1]).abs() < 1e-6);
    }

    #[test]
    fn a_centred_plan_has_no_moving_gaze() {
        let p = Plan::resolve("smoke").unwrap();
        assert_eq!(p.gaze, GazeKind::Centre);
        let fov = Fov::symmetric(0.8, 0.8);
        assert!(BenchGaze::new(&p, [fov, fov], 10, 90.0).is_none());
    }
}
