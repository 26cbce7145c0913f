//! Biogeography-based optimisation on priority vectors (the paper's BBO).
//!
//! (Implementation in progress: the settings and constructor below are the
//! agreed interface.)

use super::Solver;
use crate::problem::Problem;
use crate::rng::PlannerRng;
use crate::route::{Route, RouteEval};

/// BBO settings; [`BboSettings::paper`] gives the paper's values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BboSettings {
    /// Population (paper: 50 habitats).
    pub habitats: usize,
    /// Best habitats kept unchanged each generation (paper: 10).
    pub elites: usize,
    /// Generations of a full budget (our choice: 150, matching the PSO; the paper is silent).
    pub generations: u32,
    /// Largest per-dimension mutation probability (paper: 0.1).
    pub max_mutation_rate: f64,
}

impl BboSettings {
    /// The paper's settings.
    pub fn paper() -> Self {
        Self {
            habitats: 50,
            elites: 10,
            generations: 150,
            max_mutation_rate: 0.1,
        }
    }
}

/// A BBO solver with every buffer allocated up front.
pub struct Bbo {
    settings: BboSettings,
    best: Route,
    best_eval: RouteEval,
}

impl Bbo {
    /// Builds the solver (allocates all buffers).
    pub fn new(settings: BboSettings) -> Self {
        Self {
            settings,
            best: Route::new(),
            best_eval: RouteEval::default(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &BboSettings {
        &self.settings
    }
}

impl Solver for Bbo {
    fn name(&self) -> &'static str {
        "bbo"
    }
    fn start(&mut self, _problem: &Problem, _rng: &mut PlannerRng, _warm: Option<&Route>) {
        todo!("BBO in progress")
    }
    fn step(&mut self, _problem: &Problem, _rng: &mut PlannerRng) -> bool {
        todo!("BBO in progress")
    }
    fn best(&self) -> (&Route, &RouteEval) {
        (&self.best, &self.best_eval)
    }
}
