//! `planner mission` orchestration (in progress).
