//! Scheduler: task state, rounds, reception windows, safety router and navigation.
