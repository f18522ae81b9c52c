//! Tests of the stage pictures: every picture is written and decodes.

use super::*;
use crate::config::RetinaConfig;
use rand::rngs::StdRng;
use rand::SeedableRng;

#[test]
fn stage_pictures_are_written_and_decode() {
    let r = Retina::new(RetinaConfig {
        cones: "LMSQ".into(),
        ..RetinaConfig::tiny()
    })
    .unwrap();
    let dir = std::env::temp_dir().join(format!("retina-pictures-{}", std::process::id()));
    let files = write_stage_pictures(&r, &mut StdRng::seed_from_u64(0), &dir).unwrap();
    assert_eq!(files.len(), 9 + MOTION_PICTURE_FRAMES + 1);
    for f in &files {
        let dec = png::Decoder::new(std::io::BufReader::new(File::open(f).unwrap()));
        let info = dec.read_info().unwrap();
        assert!(info.info().width >= 64, "{}", f.display());
    }
    let anim = png::Decoder::new(std::io::BufReader::new(
        File::open(dir.join("ons_motion.png")).unwrap(),
    ))
    .read_info()
    .unwrap();
    assert_eq!(
        anim.info().animation_control().map(|a| a.num_frames),
        Some(MOTION_PICTURE_FRAMES as u32)
    );
    // The mosaic picture uses all four class colours.
    let m = RgbImage8::read(&dir.join("2_mosaic_lattice.png"));
    let amber = m.chunks(3).any(|c| c == [255, 179, 0]);
    let red = m.chunks(3).any(|c| c == [242, 38, 38]);
    assert!(amber && red);
}

struct RgbImage8;
impl RgbImage8 {
    fn read(p: &Path) -> Vec<u8> {
        let mut r = png::Decoder::new(std::io::BufReader::new(File::open(p).unwrap()))
            .read_info()
            .unwrap();
        let mut buf = vec![0; r.output_buffer_size().unwrap()];
        r.next_frame(&mut buf).unwrap();
        buf
    }
}
