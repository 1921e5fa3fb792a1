//! Observer: perception state (RGB and event receivers), frame parser, offer cache and allocation.
