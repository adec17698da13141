//! Wall-clock laps of the pipeline's stages ([`crate::Explained::timings`]).

/// Wall-clock laps of the analysis stages (see [`Explained::timings`]).
pub(crate) struct Laps {
    last: std::time::Instant,
    pub(crate) v: Vec<(String, f64)>,
}

impl Laps {
    pub(crate) fn new() -> Self {
        Self { last: std::time::Instant::now(), v: Vec::new() }
    }
    /// Ends the stage `name` (it began where the previous one ended).
    pub(crate) fn lap(&mut self, name: &str) {
        let now = std::time::Instant::now();
        self.v.push((name.to_string(), (now - self.last).as_secs_f64()));
        self.last = now;
    }
}

