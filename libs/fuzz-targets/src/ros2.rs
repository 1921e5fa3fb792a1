//! ROS 2 input (`libs/ros2`): CDR messages of a camera topic and rosbag2 MCAP bags.
//!
//! [`ros2_cdr`] takes a selector byte and one message's CDR bytes: an `event_camera_msgs`
//! `EventPacket`, a `sensor_msgs` `Image` or `CompressedImage`, or an event packet as a live
//! camera's stream takes it (remapped into the reference camera, cut into 40 ms packets). A
//! message that decodes must decode again to the same value from its own encoding, and goes
//! through what `waggle observe` and `waggle decode` do with it (the EVT 3.0 payload, the
//! pixels). [`ros2_bag`]
//! reads the bytes as a bag file, as `waggle decode --events BAG` does.

use std::path::Path;

use ros2_bag::RosMessage;
use ros2_bag::camera::CameraPackets;
use ros2_bag::ingest::{PacketDecoder, image_from_cdr, read_event_bag_bytes};
use ros2_bag::messages::{CompressedImageMsg, EventPacketMsg, ImageMsg};

/// Asserts that `msg`, decoded, comes back from its own encoding.
fn again<M: RosMessage + PartialEq + std::fmt::Debug>(
    msg: &M,
    decode: fn(&[u8]) -> Result<M, ros2_bag::CdrError>,
) {
    let back = decode(&msg.to_cdr()).expect("a message Waggle encoded decodes");
    assert_eq!(&back, msg);
}

/// Selector byte (0 event packet, 1 image, 2 compressed image, 3 a live camera's packet),
/// then CDR bytes.
pub fn ros2_cdr(data: &[u8]) {
    let Some((&selector, cdr)) = data.split_first() else {
        return;
    };
    match selector % 4 {
        0 => {
            if let Ok(msg) = EventPacketMsg::from_cdr(cdr) {
                again(&msg, EventPacketMsg::from_cdr);
            }
            let mut decoder = PacketDecoder::default();
            let mut events = Vec::new();
            let pushed = decoder.push(cdr, &mut events);
            if pushed.is_err() {
                assert!(events.is_empty(), "a refused message added events");
                assert_eq!(decoder.messages(), 0);
            }
        }
        1 => {
            if let Ok(msg) = ImageMsg::from_cdr(cdr) {
                again(&msg, ImageMsg::from_cdr);
            }
            if let Ok(image) = image_from_cdr(cdr, false) {
                let pixels = usize::from(image.width) * usize::from(image.height);
                assert_eq!(image.rgb.len(), pixels * 3);
            }
        }
        3 => {
            let mut camera = CameraPackets::new(None);
            let mut packets = 0u64;
            if camera.take(cdr, |_| packets += 1).is_err() {
                assert_eq!(packets, 0, "a refused message handed out packets");
            }
            camera.finish_stream(|_| packets += 1);
        }
        _ => {
            if let Ok(msg) = CompressedImageMsg::from_cdr(cdr) {
                again(&msg, CompressedImageMsg::from_cdr);
            }
            if let Ok(image) = image_from_cdr(cdr, true) {
                let pixels = usize::from(image.width) * usize::from(image.height);
                assert_eq!(image.rgb.len(), pixels * 3);
            }
        }
    }
}

/// A bag's MCAP file: its event topic read back into events.
pub fn ros2_bag(data: &[u8]) {
    if let Ok(bag) = read_event_bag_bytes(Path::new("fuzz.mcap"), data, None, None) {
        assert!(bag.messages > 0 || bag.events.is_empty());
    }
}
