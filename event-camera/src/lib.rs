//! Synthetic event camera: threshold-crossing converter and packetiser.
