//! Navigation at the nominal altitude: the shortest polyline that keeps a clearance from every
//! other drone.
//!
//! Straight lines are not safe: for N = 3, O3 → A passes ≈ 8 cm from O2's home. The planner
//! works in the horizontal plane (everything flies at 1.3 m) on a visibility graph whose nodes
//! are the start, the goal and `ring_points` candidates on a circle just outside each obstacle's
//! clearance circle; an edge is usable when no obstacle comes closer than its clearance. Every
//! segment is flown rest to rest, so an edge costs its flight time (see
//! [`crate::trajectory::segment_duration_ns`]); Dijkstra (ties broken by node index, so the
//! result is deterministic) gives the fastest path, which a greedy shortcut pass then strips of
//! redundant waypoints.
//!
//! An edge that starts or ends inside an obstacle's clearance (possible only with displaced
//! drones) is allowed as long as it never gets closer than its nearer endpoint already is, so
//! the planner can always leave a tight spot.

pub use crate::trajectory::planar_distance_m;
use proto::scene::PERFORMER_HOVER_M;

use crate::config::FlightLimits;
use crate::error::NavError;

/// A stationary drone or reserved point to keep away from.
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    /// For logs and test messages (`performer`, `O2`, `site B`, …).
    pub name: String,
    pub center_m: [f64; 3],
    pub clearance_m: f64,
}

/// The obstacles a mover must avoid: the performer, the other observers where they are, and the
/// sites other than its destination.
pub fn obstacles(
    others_m: impl IntoIterator<Item = (String, [f64; 3])>,
    free_sites: impl IntoIterator<Item = (String, [f64; 3])>,
    limits: &FlightLimits,
) -> Vec<Obstacle> {
    let mut out = vec![Obstacle {
        name: "performer".to_owned(),
        center_m: PERFORMER_HOVER_M,
        clearance_m: limits.performer_clearance_m,
    }];
    for (name, center_m) in others_m.into_iter().chain(free_sites) {
        out.push(Obstacle {
            name,
            center_m,
            clearance_m: limits.clearance_m,
        });
    }
    out
}

/// Horizontal distance from `p` to the segment `a`–`b`.
pub fn segment_distance_m(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let s = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    planar_distance_m(p, [a[0] + s * dx, a[1] + s * dy, 0.0])
}

/// Least clearance (distance minus required clearance) of a polyline against the obstacles;
/// negative means the polyline violates some obstacle's clearance.
pub fn path_margin_m(path: &[[f64; 3]], obstacles: &[Obstacle]) -> f64 {
    let mut margin = f64::INFINITY;
    for w in path.windows(2) {
        for o in obstacles {
            margin = margin.min(segment_distance_m(o.center_m, w[0], w[1]) - o.clearance_m);
        }
    }
    margin
}

/// Flight time of one rest-to-rest segment, seconds: paths are ranked by time, not length, so a
/// detour with fewer stops beats a slightly shorter one that weaves from waypoint to waypoint.
fn edge_cost(length_m: f64, limits: &FlightLimits) -> f64 {
    crate::trajectory::segment_duration_ns(length_m, limits).map_or(f64::INFINITY, |ns| ns as f64)
}

fn edge_ok(a: [f64; 3], b: [f64; 3], obstacles: &[Obstacle]) -> bool {
    obstacles.iter().all(|o| {
        let need = o
            .clearance_m
            .min(planar_distance_m(o.center_m, a))
            .min(planar_distance_m(o.center_m, b));
        segment_distance_m(o.center_m, a, b) >= need - 1e-9
    })
}

/// The fastest safe polyline from `from_m` to `to_m`, both ends included. Altitude is
/// interpolated linearly along the path (homes and sites share the 1.3 m nominal altitude, so
/// in practice it stays constant).
pub fn plan_path(
    from_m: [f64; 3],
    to_m: [f64; 3],
    obstacles: &[Obstacle],
    limits: &FlightLimits,
) -> Result<Vec<[f64; 3]>, NavError> {
    for p in [from_m, to_m]
        .into_iter()
        .chain(obstacles.iter().map(|o| o.center_m))
    {
        if p.iter().any(|v| !v.is_finite()) {
            return Err(NavError::NonFinite(p));
        }
    }
    let mut nodes = vec![from_m, to_m];
    let n_ring = limits.ring_points;
    for o in obstacles {
        let r = o.clearance_m + limits.ring_margin_m;
        for k in 0..n_ring {
            let a = std::f64::consts::TAU * k as f64 / n_ring as f64;
            let p = [
                o.center_m[0] + r * a.cos(),
                o.center_m[1] + r * a.sin(),
                from_m[2],
            ];
            let free = obstacles
                .iter()
                .all(|q| planar_distance_m(q.center_m, p) >= q.clearance_m);
            if free {
                nodes.push(p);
            }
        }
    }
    // Dijkstra over the complete visibility graph, O(V²); V ≤ 2 + 10 · ring_points.
    let v = nodes.len();
    let mut dist = vec![f64::INFINITY; v];
    let mut prev = vec![usize::MAX; v];
    let mut done = vec![false; v];
    dist[0] = 0.0;
    loop {
        let mut cur = usize::MAX;
        for i in 0..v {
            if !done[i] && dist[i].is_finite() && (cur == usize::MAX || dist[i] < dist[cur]) {
                cur = i;
            }
        }
        if cur == usize::MAX || cur == 1 {
            break;
        }
        done[cur] = true;
        for j in 0..v {
            if done[j] {
                continue;
            }
            let d = dist[cur] + edge_cost(planar_distance_m(nodes[cur], nodes[j]), limits);
            if d < dist[j] && edge_ok(nodes[cur], nodes[j], obstacles) {
                dist[j] = d;
                prev[j] = cur;
            }
        }
    }
    if !dist[1].is_finite() {
        return Err(NavError::NoPath { from_m, to_m });
    }
    let mut chain = vec![1];
    while let Some(&last) = chain.last() {
        if last == 0 {
            break;
        }
        chain.push(prev[last]);
    }
    chain.reverse();
    let raw: Vec<[f64; 3]> = chain.into_iter().map(|i| nodes[i]).collect();
    // Greedy shortcut: from each kept waypoint jump to the farthest one still reachable.
    let mut path = vec![raw[0]];
    let mut i = 0;
    while i + 1 < raw.len() {
        let mut j = raw.len() - 1;
        while j > i + 1 && !edge_ok(raw[i], raw[j], obstacles) {
            j -= 1;
        }
        path.push(raw[j]);
        i = j;
    }
    // Altitude along the path.
    let total: f64 = path.windows(2).map(|w| planar_distance_m(w[0], w[1])).sum();
    let mut run = 0.0;
    let last = path.len() - 1;
    for k in 0..path.len() {
        if k > 0 {
            run += planar_distance_m(path[k - 1], path[k]);
        }
        path[k][2] = if k == last || total <= 0.0 {
            if k == last { to_m[2] } else { from_m[2] }
        } else {
            from_m[2] + (to_m[2] - from_m[2]) * run / total
        };
    }
    path[0] = from_m;
    path[last] = to_m;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Site;
    use proto::scene::observer_home_m;

    fn scene_obstacles(n: usize, mover: usize, site: Site) -> Vec<Obstacle> {
        let limits = FlightLimits::default();
        obstacles(
            (0..n)
                .filter(|&j| j != mover)
                .map(|j| (format!("O{}", j + 1), observer_home_m(j, n))),
            Site::ALL
                .into_iter()
                .filter(|&s| s != site)
                .map(|s| (format!("site {s}"), s.position_m())),
            &limits,
        )
    }

    #[test]
    fn the_straight_line_o3_to_a_grazes_o2_and_the_planner_goes_around() {
        let obs = scene_obstacles(3, 2, Site::A);
        let home = observer_home_m(2, 3);
        let o2 = observer_home_m(1, 3);
        let straight = segment_distance_m(o2, home, Site::A.position_m());
        assert!(straight < 0.10, "straight line passes {straight} m from O2");
        let path = plan_path(home, Site::A.position_m(), &obs, &FlightLimits::default()).unwrap();
        assert!(path.len() >= 3, "needs a detour: {path:?}");
        assert!(path_margin_m(&path, &obs) >= -1e-9);
        assert_eq!(path[0], home);
        assert_eq!(*path.last().unwrap(), Site::A.position_m());
        assert!(path.iter().all(|p| p[2] == 1.3));
    }

    #[test]
    fn a_clear_straight_line_is_kept_as_one_segment() {
        let obs = scene_obstacles(3, 0, Site::A);
        let home = observer_home_m(0, 3);
        let path = plan_path(home, Site::A.position_m(), &obs, &FlightLimits::default()).unwrap();
        assert_eq!(path, vec![home, Site::A.position_m()]);
    }

    #[test]
    fn planning_is_deterministic_and_rejects_garbage() {
        let obs = scene_obstacles(8, 0, Site::B);
        let home = observer_home_m(0, 8);
        let l = FlightLimits::default();
        let a = plan_path(home, Site::B.position_m(), &obs, &l).unwrap();
        let b = plan_path(home, Site::B.position_m(), &obs, &l).unwrap();
        assert_eq!(a, b);
        assert!(matches!(
            plan_path([f64::NAN, 0.0, 1.3], Site::B.position_m(), &obs, &l),
            Err(NavError::NonFinite(_))
        ));
        // A goal inside a wall of obstacles that leaves no gap is reported, not panicked on.
        let goal = [5.0, 5.0, 1.3];
        let wall: Vec<Obstacle> = (0..64)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 64.0;
                Obstacle {
                    name: format!("w{k}"),
                    center_m: [goal[0] + 0.5 * a.cos(), goal[1] + 0.5 * a.sin(), 1.3],
                    clearance_m: 0.35,
                }
            })
            .collect();
        assert!(matches!(
            plan_path(home, goal, &wall, &l),
            Err(NavError::NoPath { .. })
        ));
    }

    #[test]
    fn a_start_inside_a_clearance_can_still_leave_without_getting_closer() {
        let l = FlightLimits::default();
        let obs = vec![Obstacle {
            name: "x".into(),
            center_m: [0.2, 0.0, 1.3],
            clearance_m: 0.35,
        }];
        let path = plan_path([0.0, 0.0, 1.3], [3.0, 0.0, 1.3], &obs, &l).unwrap();
        let start_d = 0.2;
        for w in path.windows(2) {
            assert!(segment_distance_m(obs[0].center_m, w[0], w[1]) >= start_d - 1e-9);
        }
    }
}
