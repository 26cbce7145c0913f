//! Particle swarm optimisation on priority vectors (the paper's PSO).
