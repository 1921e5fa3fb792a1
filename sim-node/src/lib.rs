//! MuJoCo physics, scene generation and headless rendering for Waggle.
