//! Event-frame pictures, insets and PNG round trips.

use event_camera::PictureError;
use event_camera::picture::{
    Corner, Inset, NO_EVENT_COLOUR, OFF_COLOUR, ON_COLOUR, OUTLINE_COLOUR, RgbImage, decode_png,
    encode_png, event_frame, event_picture, filled, from_rgb, with_inset,
};
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use proto::{EventPacket, Polarity};

fn packet(width: u16, height: u16, events: &[(u16, u16, Polarity)]) -> EventPacket {
    let events: Vec<_> = (1..)
        .zip(events)
        .map(|(dt_ns, &(x, y, p))| (x, y, dt_ns, p))
        .collect();
    EventPacket::from_events(3, (0, 40_000_000), (width, height), &events)
}

fn pixel(image: &RgbImage, x: u32, y: u32) -> [u8; 3] {
    image.get_pixel(x, y).0
}

#[test]
fn on_is_blue_off_is_red_last_polarity_wins_and_the_rest_is_white() {
    use Polarity::{Off, On};
    let p = packet(
        6,
        5,
        &[
            (1, 1, On),
            (2, 1, Off),
            (3, 3, On),
            (3, 3, Off),
            (4, 4, Off),
            (4, 4, On),
            (0, 4, On),
        ],
    );
    let image = event_frame(&p).unwrap();
    assert_eq!((image.width(), image.height()), (6, 5));
    assert_eq!(pixel(&image, 1, 1), ON_COLOUR);
    assert_eq!(pixel(&image, 2, 1), OFF_COLOUR);
    assert_eq!(pixel(&image, 3, 3), OFF_COLOUR);
    assert_eq!(pixel(&image, 4, 4), ON_COLOUR);
    assert_eq!(pixel(&image, 0, 4), ON_COLOUR);
    assert_eq!(ON_COLOUR, [0, 0, 255]);
    assert_eq!(OFF_COLOUR, [255, 0, 0]);
    let coloured = [(1, 1), (2, 1), (3, 3), (4, 4), (0, 4)];
    for y in 0..5 {
        for x in 0..6 {
            if !coloured.contains(&(x, y)) {
                assert_eq!(pixel(&image, x, y), NO_EVENT_COLOUR, "({x}, {y})");
            }
        }
    }
    // An empty packet is a white picture.
    assert!(
        event_frame(&packet(6, 5, &[]))
            .unwrap()
            .as_raw()
            .iter()
            .all(|&b| b == 255)
    );
}

#[test]
fn malformed_packets_are_errors_not_panics() {
    let mut p = packet(4, 4, &[(4, 0, Polarity::On)]);
    assert!(matches!(
        event_frame(&p),
        Err(PictureError::MalformedPacket(_))
    ));
    p.xs[0] = 0;
    p.on_bits.clear();
    assert!(matches!(
        event_frame(&p),
        Err(PictureError::MalformedPacket(_))
    ));
    p.on_bits = vec![1];
    p.ys.push(0);
    assert!(matches!(
        event_frame(&p),
        Err(PictureError::MalformedPacket(_))
    ));
}

#[test]
fn inset_magnifies_the_crop_into_the_corner_and_outlines_it() {
    // A 100×80 gradient image, crop 10×8 at (40, 30), magnified 3× top-right.
    let rgb: Vec<u8> = (0..80u32)
        .flat_map(|y| (0..100u32).flat_map(move |x| [x as u8, y as u8, 7]))
        .collect();
    let image = from_rgb(100, 80, rgb).unwrap();
    let inset = Inset {
        x: 40,
        y: 30,
        width: 10,
        height: 8,
        scale: 3,
        corner: Corner::TopRight,
    };
    let out = with_inset(&image, &inset).unwrap();
    // Box = 10·3 + 2·2 border = 34 wide, 28 high; margin 6 → starts at x = 100 − 6 − 34 = 60.
    let (bx, by) = (60, 6);
    assert_eq!(pixel(&out, bx, by), OUTLINE_COLOUR);
    assert_eq!(pixel(&out, bx + 33, by + 27), OUTLINE_COLOUR);
    for py in 0..24 {
        for px in 0..30 {
            assert_eq!(
                pixel(&out, bx + 2 + px, by + 2 + py),
                pixel(&image, 40 + px / 3, 30 + py / 3),
                "inset ({px}, {py})"
            );
        }
    }
    // Outline one pixel outside the crop; the crop itself and the rest are untouched.
    assert_eq!(pixel(&out, 39, 29), OUTLINE_COLOUR);
    assert_eq!(pixel(&out, 50, 38), OUTLINE_COLOUR);
    assert_eq!(pixel(&out, 45, 29), OUTLINE_COLOUR);
    assert_eq!(pixel(&out, 40, 30), pixel(&image, 40, 30));
    assert_eq!(pixel(&out, 49, 37), pixel(&image, 49, 37));
    assert_eq!(pixel(&out, 10, 70), pixel(&image, 10, 70));
    // Other corners.
    let bl = with_inset(
        &image,
        &Inset {
            corner: Corner::BottomLeft,
            ..inset
        },
    )
    .unwrap();
    assert_eq!(pixel(&bl, 6 + 2, 80 - 6 - 28 + 2), pixel(&image, 40, 30));
    assert_eq!(pixel(&bl, 70, 10), pixel(&image, 70, 10));
}

#[test]
fn inset_that_does_not_fit_is_an_error() {
    let image = filled(100, 80, [1, 2, 3]);
    let inset = Inset {
        x: 95,
        y: 0,
        width: 10,
        height: 8,
        scale: 1,
        corner: Corner::TopLeft,
    };
    assert!(matches!(
        with_inset(&image, &inset),
        Err(PictureError::CropOutside { .. })
    ));
    let huge = Inset {
        x: 0,
        y: 0,
        width: 40,
        height: 8,
        scale: 3,
        corner: Corner::TopLeft,
    };
    assert!(matches!(
        with_inset(&image, &huge),
        Err(PictureError::InsetTooLarge { .. })
    ));
    let empty = Inset { width: 0, ..huge };
    assert!(matches!(
        with_inset(&image, &empty),
        Err(PictureError::EmptyInset)
    ));
    let overflow = Inset {
        x: u32::MAX,
        ..inset
    };
    assert!(matches!(
        with_inset(&image, &overflow),
        Err(PictureError::CropOutside { .. })
    ));
}

#[test]
fn paper_inset_is_80_by_60_inside_the_field() {
    let inset = Inset::paper(320, 240);
    assert_eq!(
        (inset.x, inset.y, inset.width, inset.height),
        (280, 210, 80, 60)
    );
    let edge = Inset::paper(635, 2);
    assert_eq!((edge.x, edge.y), (560, 0));
    let p = packet(640, 480, &[(320, 240, Polarity::On)]);
    let picture = event_picture(&p, Some(&inset)).unwrap();
    assert_eq!(pixel(&picture, 320, 240), ON_COLOUR);
    // The event appears magnified in the inset too: crop offset (40, 30) × 3 + border.
    let (bx, by) = (640 - 6 - (80 * 3 + 4), 6);
    assert_eq!(pixel(&picture, bx + 2 + 40 * 3, by + 2 + 30 * 3), ON_COLOUR);
    assert_eq!(event_picture(&p, None).unwrap(), event_frame(&p).unwrap());
}

#[test]
fn png_round_trip_and_decoding() {
    let rgb: Vec<u8> = (0..7 * 5 * 3).map(|i| (i * 11 % 256) as u8).collect();
    let image = from_rgb(7, 5, rgb).unwrap();
    let bytes = encode_png(&image).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(decode_png(&bytes).unwrap(), image);

    // Gray and RGBA inputs normalise to RGB (gray replicated, alpha dropped).
    let encode = |color: ExtendedColorType, data: &[u8]| {
        let mut out = Vec::new();
        PngEncoder::new(&mut out)
            .write_image(data, 2, 1, color)
            .unwrap();
        out
    };
    let gray = decode_png(&encode(ExtendedColorType::L8, &[9, 200])).unwrap();
    assert_eq!(gray.as_raw(), &vec![9, 9, 9, 200, 200, 200]);
    let rgba = decode_png(&encode(
        ExtendedColorType::Rgba8,
        &[1, 2, 3, 0, 4, 5, 6, 255],
    ))
    .unwrap();
    assert_eq!(rgba.as_raw(), &vec![1, 2, 3, 4, 5, 6]);

    assert!(matches!(
        decode_png(b"not a png"),
        Err(PictureError::Png(_))
    ));
    assert!(matches!(
        decode_png(&bytes[..bytes.len() / 2]),
        Err(PictureError::Png(_))
    ));
    assert!(matches!(
        from_rgb(2, 2, vec![0; 11]),
        Err(PictureError::BufferSize { .. })
    ));
}
