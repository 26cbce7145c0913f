//! Biogeography-based optimisation on priority vectors (the paper's BBO).
