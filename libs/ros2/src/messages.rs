//! The standard ROS 2 messages a Waggle bag holds, field for field as their Jazzy interfaces
//! declare them (our definitions in `libs/ros2/msg/ros_interfaces/`), with their CDR encoding.

use crate::cdr::{CdrEncode, CdrWriter, RosMessage};
use crate::error::Ros2Error;

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TimeMsg {
    pub sec: i32,
    pub nanosec: u32,
}

impl TimeMsg {
    /// A sim time in nanoseconds (ROS time here is the sim clock, from 0).
    pub fn from_ns(time_ns: u64) -> Result<Self, Ros2Error> {
        let sec = i32::try_from(time_ns / 1_000_000_000)
            .map_err(|_| Ros2Error::TimeOutOfRange { time_ns })?;
        Ok(Self {
            sec,
            nanosec: (time_ns % 1_000_000_000) as u32,
        })
    }
}

impl CdrEncode for TimeMsg {
    fn encode(&self, w: &mut CdrWriter) {
        w.i32(self.sec);
        w.u32(self.nanosec);
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct HeaderMsg {
    pub stamp: TimeMsg,
    pub frame_id: String,
}

impl HeaderMsg {
    pub fn at(time_ns: u64, frame_id: impl Into<String>) -> Result<Self, Ros2Error> {
        Ok(Self {
            stamp: TimeMsg::from_ns(time_ns)?,
            frame_id: frame_id.into(),
        })
    }
}

impl CdrEncode for HeaderMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.stamp.encode(w);
        w.string(&self.frame_id);
    }
}

/// `sensor_msgs/msg/CompressedImage`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CompressedImageMsg {
    pub header: HeaderMsg,
    /// `ORIG_PIXFMT; CODEC compressed COMPRESSED_PIXFMT`, e.g. `rgb8; png compressed bgr8`.
    pub format: String,
    pub data: Vec<u8>,
}

impl CdrEncode for CompressedImageMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.format);
        w.bytes(&self.data);
    }
}

impl RosMessage for CompressedImageMsg {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/CompressedImage";
}

/// `sensor_msgs/msg/Image`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImageMsg {
    pub header: HeaderMsg,
    pub height: u32,
    pub width: u32,
    pub encoding: String,
    pub is_bigendian: u8,
    /// Row length, bytes.
    pub step: u32,
    pub data: Vec<u8>,
}

impl CdrEncode for ImageMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.u32(self.height);
        w.u32(self.width);
        w.string(&self.encoding);
        w.u8(self.is_bigendian);
        w.u32(self.step);
        w.bytes(&self.data);
    }
}

impl RosMessage for ImageMsg {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/Image";
}

/// `sensor_msgs/msg/RegionOfInterest`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RegionOfInterestMsg {
    pub x_offset: u32,
    pub y_offset: u32,
    pub height: u32,
    pub width: u32,
    pub do_rectify: bool,
}

impl CdrEncode for RegionOfInterestMsg {
    fn encode(&self, w: &mut CdrWriter) {
        w.u32(self.x_offset);
        w.u32(self.y_offset);
        w.u32(self.height);
        w.u32(self.width);
        w.bool(self.do_rectify);
    }
}

/// `sensor_msgs/msg/CameraInfo`.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraInfoMsg {
    pub header: HeaderMsg,
    pub height: u32,
    pub width: u32,
    pub distortion_model: String,
    pub d: Vec<f64>,
    pub k: [f64; 9],
    pub r: [f64; 9],
    pub p: [f64; 12],
    pub binning_x: u32,
    pub binning_y: u32,
    pub roi: RegionOfInterestMsg,
}

impl CdrEncode for CameraInfoMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.u32(self.height);
        w.u32(self.width);
        w.string(&self.distortion_model);
        w.f64_sequence(&self.d);
        w.f64_array(&self.k);
        w.f64_array(&self.r);
        w.f64_array(&self.p);
        w.u32(self.binning_x);
        w.u32(self.binning_y);
        self.roi.encode(w);
    }
}

impl RosMessage for CameraInfoMsg {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/CameraInfo";
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vector3Msg {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl CdrEncode for Vector3Msg {
    fn encode(&self, w: &mut CdrWriter) {
        w.f64(self.x);
        w.f64(self.y);
        w.f64(self.z);
    }
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuaternionMsg {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl QuaternionMsg {
    /// From Waggle's (w, x, y, z) order.
    pub fn from_wxyz(q: [f64; 4]) -> Self {
        Self {
            x: q[1],
            y: q[2],
            z: q[3],
            w: q[0],
        }
    }
}

impl CdrEncode for QuaternionMsg {
    fn encode(&self, w: &mut CdrWriter) {
        w.f64(self.x);
        w.f64(self.y);
        w.f64(self.z);
        w.f64(self.w);
    }
}

/// `geometry_msgs/msg/TransformStamped`: `child_frame_id` in `header.frame_id`.
#[derive(Debug, Clone, PartialEq)]
pub struct TransformStampedMsg {
    pub header: HeaderMsg,
    pub child_frame_id: String,
    pub translation: Vector3Msg,
    pub rotation: QuaternionMsg,
}

impl CdrEncode for TransformStampedMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.string(&self.child_frame_id);
        // geometry_msgs/msg/Transform
        self.translation.encode(w);
        self.rotation.encode(w);
    }
}

/// `tf2_msgs/msg/TFMessage`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TfMessage {
    pub transforms: Vec<TransformStampedMsg>,
}

impl CdrEncode for TfMessage {
    fn encode(&self, w: &mut CdrWriter) {
        self.transforms.encode(w);
    }
}

impl RosMessage for TfMessage {
    const TYPE_NAME: &'static str = "tf2_msgs/msg/TFMessage";
}

/// `event_camera_msgs/msg/EventPacket`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EventPacketMsg {
    pub header: HeaderMsg,
    pub height: u32,
    pub width: u32,
    pub seq: u64,
    /// Event ROS time = `time_base` + decoded event time.
    pub time_base: u64,
    /// `evt3` here.
    pub encoding: String,
    pub is_bigendian: bool,
    pub events: Vec<u8>,
}

impl CdrEncode for EventPacketMsg {
    fn encode(&self, w: &mut CdrWriter) {
        self.header.encode(w);
        w.u32(self.height);
        w.u32(self.width);
        w.u64(self.seq);
        w.u64(self.time_base);
        w.string(&self.encoding);
        w.bool(self.is_bigendian);
        w.bytes(&self.events);
    }
}

impl RosMessage for EventPacketMsg {
    const TYPE_NAME: &'static str = "event_camera_msgs/msg/EventPacket";
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_header_and_an_event_packet_encode_as_hand_computed() {
        let msg = EventPacketMsg {
            header: HeaderMsg::at(1_500_000_123, "O1").unwrap(),
            height: 480,
            width: 640,
            seq: 2,
            time_base: 0,
            encoding: "evt3".into(),
            is_bigendian: false,
            events: vec![0x34, 0x12],
        };
        #[rustfmt::skip]
        let want: Vec<u8> = vec![
            0x00, 0x01, 0x00, 0x00,
            0x01, 0x00, 0x00, 0x00,             // stamp.sec = 1           offset 0
            0x7B, 0x65, 0xCD, 0x1D,             // nanosec = 500 000 123          4
            0x03, 0x00, 0x00, 0x00, b'O', b'1', 0x00, // frame_id "O1"           8
            0x00,                               // pad to 16                     15
            0xE0, 0x01, 0x00, 0x00,             // height 480                    16
            0x80, 0x02, 0x00, 0x00,             // width 640                     20
            0x02, 0, 0, 0, 0, 0, 0, 0,          // seq (aligned at 24)           24
            0, 0, 0, 0, 0, 0, 0, 0,             // time_base                     32
            0x05, 0x00, 0x00, 0x00, b'e', b'v', b't', b'3', 0x00, // "evt3"      40
            0x00,                               // is_bigendian                  49
            0x00, 0x00,                         // pad to 52                     50
            0x02, 0x00, 0x00, 0x00, 0x34, 0x12, // events                        52
        ];
        assert_eq!(msg.to_cdr(), want);
    }

    #[test]
    fn times_beyond_int32_seconds_are_refused() {
        assert!(TimeMsg::from_ns((i32::MAX as u64 + 1) * 1_000_000_000).is_err());
        assert_eq!(
            TimeMsg::from_ns(2_000_000_001).unwrap(),
            TimeMsg { sec: 2, nanosec: 1 }
        );
    }
}
