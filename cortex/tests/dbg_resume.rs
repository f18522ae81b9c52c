use cortex::checkpoint::latest_checkpoint;
use cortex::config::CortexConfig;
use cortex::synthetic::{SyntheticConfig, SyntheticSource};
use cortex::Trainer;

#[test]
fn dbg() {
    let cfg = CortexConfig::tiny();
    let dir = std::env::temp_dir().join("cortex-dbg");
    let _ = std::fs::remove_dir_all(&dir);
    let mut a = Trainer::new(cfg.clone()).unwrap();
    let mut src = SyntheticSource::new(SyntheticConfig::lms(32, 5));
    a.run(&mut src, 2, Some(&dir), |_, _| {}).unwrap();
    let ck = latest_checkpoint(&dir).unwrap().unwrap();
    let mut src2 = SyntheticSource::new(SyntheticConfig::lms(32, 5));
    let mut b = Trainer::resume(&ck, Some(&mut src2)).unwrap();
    for id in a.cortex.params.ids() {
        let same = a.cortex.params.get(id).data() == b.cortex.params.get(id).data();
        if !same { println!("param {} differs right after resume", a.cortex.params.name(id)); }
    }
    let ba = src.next_batch(4);
    let bb = src2.next_batch(4);
    println!("batches equal: {}", ba == bb);
    let sa = a.step(&ba).unwrap();
    let sb = b.step(&bb).unwrap();
    println!("loss {} {}", sa.loss, sb.loss);
    for id in a.cortex.params.ids() {
        let pa = a.cortex.params.get(id);
        let pb = b.cortex.params.get(id);
        if pa.data() != pb.data() { println!("param {} differs after step: {}", a.cortex.params.name(id), pa.max_abs_diff(pb)); }
    }
}
