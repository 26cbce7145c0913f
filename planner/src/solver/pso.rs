//! Particle swarm optimisation on priority vectors (the paper's PSO).
//!
//! (Implementation in progress: the settings and constructor below are the
//! agreed interface.)

use super::Solver;
use crate::problem::Problem;
use crate::rng::PlannerRng;
use crate::route::{Route, RouteEval};

/// PSO settings; [`PsoSettings::paper`] gives the paper's values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsoSettings {
    /// Swarm size (paper: 150).
    pub particles: usize,
    /// Iterations of a full budget (paper: 150).
    pub iterations: u32,
    /// Cognitive coefficient c1 (paper: 2.0).
    pub c1: f64,
    /// Social coefficient c2 (paper: 2.5).
    pub c2: f64,
    /// Inertia at the first iteration (paper: 1.4).
    pub inertia_start: f64,
    /// Inertia at the last iteration (paper: 0.5).
    pub inertia_end: f64,
}

impl PsoSettings {
    /// The paper's settings.
    pub fn paper() -> Self {
        Self {
            particles: 150,
            iterations: 150,
            c1: 2.0,
            c2: 2.5,
            inertia_start: 1.4,
            inertia_end: 0.5,
        }
    }
}

/// A PSO solver with every buffer allocated up front.
pub struct Pso {
    settings: PsoSettings,
    best: Route,
    best_eval: RouteEval,
}

impl Pso {
    /// Builds the solver (allocates all buffers).
    pub fn new(settings: PsoSettings) -> Self {
        Self {
            settings,
            best: Route::new(),
            best_eval: RouteEval::default(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &PsoSettings {
        &self.settings
    }
}

impl Solver for Pso {
    fn name(&self) -> &'static str {
        "pso"
    }
    fn start(&mut self, _problem: &Problem, _rng: &mut PlannerRng, _warm: Option<&Route>) {
        todo!("PSO in progress")
    }
    fn step(&mut self, _problem: &Problem, _rng: &mut PlannerRng) -> bool {
        todo!("PSO in progress")
    }
    fn best(&self) -> (&Route, &RouteEval) {
        (&self.best, &self.best_eval)
    }
}
