//! Performer: gesture generation for the motion alphabet (setpoint trajectories, broadcast timelines).
