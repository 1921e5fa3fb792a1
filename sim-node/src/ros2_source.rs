//! A camera process whose camera is real (`sim-node camera --ros2-source TOPIC`): its event
//! packets come from a ROS 2 topic on `rmw_zenoh` (`event_camera_msgs/msg/EventPacket` in
//! `evt3`, as Prophesee's `metavision_driver` publishes it) instead of a render, so the
//! observer process, the scheduler's session controls and everything downstream run unchanged
//! on a real sensor.
//!
//! The camera's messages are cut into the session's 40 ms packets by
//! [`ros2_bag::camera::CameraPackets`] (remapped into the reference camera through a
//! calibration file, if given) from t = 0 of the camera's clock, which must be the session's:
//! packet k is published once the session has reached its end (`sim/state` at (k+1)·40 ms) and
//! the camera's stream has passed it, the same moment a rendering camera publishes it. A packet
//! the camera has not delivered by then goes out when it arrives; the observer's grace period
//! judges one that never does. Messages that do not decode are counted and logged, never
//! fatal. Once every publisher of the topic has left, the packets up to its last event or clock
//! word go out and the stream ends.

use std::collections::VecDeque;
use std::time::Duration;

use anyhow::{Context, Result};
use node_args::Ros2Source;
use proto::{EventPacket, ObserverId};
use ros2_bag::camera::CameraPackets;
use ros2_bag::live::{LiveInput, LiveOptions, LiveSubscription, LiveView};

/// The type the source topic carries.
const TYPE_NAME: &str = "event_camera_msgs/msg/EventPacket";

/// A real camera on a ROS 2 topic, as packets.
pub struct Ros2Camera {
    /// Keeps the node and its tokens declared.
    _view: LiveView,
    subscription: LiveSubscription,
    packets: CameraPackets,
    ready: VecDeque<EventPacket>,
    messages: u64,
    refused: u64,
    gone: bool,
}

impl Ros2Camera {
    /// Joins the ROS graph as node `waggle_camera_<o>` and subscribes to the source topic.
    pub fn start(source: &Ros2Source, topic: &str, observer: &ObserverId) -> Result<Self> {
        let options = LiveOptions {
            domain: source.domain,
            router: source.router.clone(),
            observers: 0,
            session: format!("{observer}'s camera {topic}"),
        };
        let node = format!("waggle_camera_{}", observer.as_str().to_ascii_lowercase());
        let mut view = LiveView::start_node(&options, &node)
            .with_context(|| format!("--ros2-source {topic}: joining the ROS graph"))?;
        let subscription = view
            .subscribe(topic, TYPE_NAME)
            .with_context(|| format!("--ros2-source {topic}"))?;
        Ok(Self {
            _view: view,
            subscription,
            packets: CameraPackets::new(source.calibration.as_deref()),
            ready: VecDeque::new(),
            messages: 0,
            refused: 0,
            gone: false,
        })
    }

    /// Takes what has arrived, without waiting.
    pub fn poll(&mut self) {
        while !self.gone {
            let ready = &mut self.ready;
            match self.subscription.next(Duration::ZERO) {
                LiveInput::Message(cdr) => {
                    self.messages += 1;
                    if let Err(why) = self.packets.take(&cdr, |p| ready.push_back(p)) {
                        self.refused += 1;
                        if self.refused <= 5 {
                            tracing::warn!(topic = self.subscription.topic(), message = self.messages - 1, %why, "camera message refused");
                        }
                    }
                }
                LiveInput::PublishersGone => {
                    self.gone = true;
                    self.packets.finish_stream(|p| ready.push_back(p));
                    tracing::info!(
                        topic = self.subscription.topic(),
                        messages = self.messages,
                        refused = self.refused,
                        events = self.packets.events(),
                        late = self.packets.late(),
                        "the ROS 2 camera has left"
                    );
                }
                LiveInput::Idle => return,
            }
        }
    }

    /// The next packet whose interval has ended by `t_ns`, if it has arrived.
    pub fn due(&mut self, t_ns: u64) -> Option<EventPacket> {
        if self.ready.front().is_some_and(|p| p.end_ns <= t_ns) {
            self.ready.pop_front()
        } else {
            None
        }
    }
}
