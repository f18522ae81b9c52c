//! Rendering shows through the eye and the decoder: directly, or from the per-location cache
//! of unit-disc responses when the eye is noise-free (see the parent module's docs, **Speed**),
//! and the batched decoding jobs behind [`Observer::percepts`].

use super::*;
use cortex::{OutputBox, Window};
use std::collections::BTreeMap;

pub(super) mod external;

/// Entries by location (bit patterns of x, y) and the bytes they hold.
#[derive(Default)]
pub(super) struct LocationCache {
    entries: HashMap<[u64; 2], Arc<LocationEntry>>,
    bytes: usize,
}

/// What the observer keeps per patch location.
/// The size of a cached location's entry itself (its vectors' headers and its window), bytes.
pub(crate) const LOCATION_ENTRY_BYTES: usize = std::mem::size_of::<LocationEntry>();

struct LocationEntry {
    /// The cones read.
    cells: Vec<usize>,
    /// For the cortex: where its decoder D runs for this location (`None`: the whole field).
    window: Option<WindowRead>,
    /// Noise-free, per cone-read plane: the ONS of a unit disc `(k × n·n)` for the cortex
    /// decoding the whole field and for decoders from outside, the readout of its percept
    /// `(k × readout length)` for linear decoders; empty with noise.
    ons_basis: Vec<f32>,
    /// Noise-free, for the cortex decoding windows: the cone activations W's inverse makes of
    /// each plane's unit-disc ONS, cut to the window, `(k × window height × width)` (W's
    /// inverse is linear, so a show's activations are their sum weighted by its class values).
    activation_basis: Vec<f32>,
    readout_basis: Vec<f64>,
}

/// A patch's decode on a window: the window D's encoder runs on, the box of the cones read
/// inside it (D's decoder runs where that box reaches, `cortex::window` docs), and the cones
/// read as indices inside the box.
#[derive(Clone)]
struct WindowRead {
    window: Window,
    out_box: OutputBox,
    local: Vec<usize>,
}

thread_local! {
    /// Each thread's decoding tape (with its buffer pool), kept between calls: CMF-SIM makes
    /// many small calls, and fresh pages per call would dominate them. (A tape holds `dyn Op`s
    /// and is not `Send`, so it lives in the rayon worker threads.)
    static TAPE: std::cell::Cell<Option<Tape<f32>>> = const { std::cell::Cell::new(None) };
}

impl EyeObserver<'_> {
    /// The activations and ONS `(n·n)` each of one show, rendered directly.
    pub fn render(&self, show: &Show) -> (Vec<f32>, Vec<f32>) {
        let values = self
            .retina
            .class_values(&show.stimulus.to_grid(self.retina.grid()));
        self.render_values(&values, show.location, self.noise(show.noise_seed))
    }

    fn render_values(
        &self,
        values: &[f64],
        location: [f64; 2],
        noise: Option<NoiseDraw>,
    ) -> (Vec<f32>, Vec<f32>) {
        let nn = self.retina.n() * self.retina.n();
        let (mut act, mut ons) = (vec![0f32; nn], vec![0f32; nn]);
        self.retina
            .encode_disc(self.disc(location), values, noise, &mut act, &mut ons);
        (act, ons)
    }

    /// The percept image `(dim, n·n)` of linear decoders, from a frame's activations and ONS
    /// (`noise_free`: the activations are exactly those behind the ONS).
    pub(super) fn linear_percept(&self, act: &[f32], ons: &[f32], noise_free: bool) -> Vec<f32> {
        match &self.decoder {
            Decoder::Ons => ons.to_vec(),
            Decoder::Cones => act.to_vec(),
            Decoder::Oracle(o) => {
                let a = OracleDecoder::activations(self.retina, ons, noise_free.then_some(act));
                let mut out = vec![0f32; oracle::ORACLE_PERCEPT_DIM * act.len()];
                o.decode(&a, &mut out);
                out
            }
            Decoder::Cortex(_) | Decoder::External(_) => {
                unreachable!("the cortex and external decoders are decoded in batches")
            }
        }
    }

    /// The cached entry of `location` (computed on first use).
    fn location_entry(&self, location: [f64; 2]) -> Arc<LocationEntry> {
        let key = [location[0].to_bits(), location[1].to_bits()];
        if let Some(e) = self.cache.lock().expect("cache lock").entries.get(&key) {
            return e.clone();
        }
        let cells = self
            .readout
            .cells(&self.retina.layout, self.disc(location).centre_px);
        let window = self.decode_window(&cells);
        let (mut ons_basis, mut readout_basis) = (Vec::new(), Vec::new());
        if self.settings.noise_ratio == 0.0 {
            let (k, dim) = (self.retina.classes_read(), self.decoder.dim());
            // Exactly k planes: a basis grown plane by plane would keep room for a fourth.
            match self.decoder.is_linear() {
                true => readout_basis.reserve_exact(k * self.readout.len(dim)),
                false => ons_basis.reserve_exact(k * self.retina.n() * self.retina.n()),
            }
            for c in 0..k {
                let mut unit = vec![0.0; c + 1];
                unit[c] = 1.0;
                let (act, ons) = self.render_values(&unit, location, None);
                if self.decoder.is_linear() {
                    let planes = self.linear_percept(&act, &ons, true);
                    let mut r = vec![0.0; self.readout.len(dim)];
                    self.readout.read(&planes, dim, &cells, &mut r);
                    readout_basis.extend(r);
                } else {
                    ons_basis.extend(ons);
                }
            }
        }
        let activation_basis = match (&self.decoder, &window) {
            (Decoder::Cortex(cortex), Some(WindowRead { window: w, .. }))
                if !ons_basis.is_empty() =>
            {
                let (k, n) = (self.retina.classes_read(), self.retina.n());
                let pa = cortex.activations(&ons_basis, k);
                let mut cut = vec![0f32; k * w.height * w.width];
                for (plane, out) in pa.chunks_exact(n * n).zip(cut.chunks_exact_mut(w.area())) {
                    w.cut(plane, n, out);
                }
                ons_basis = Vec::new();
                cut
            }
            _ => Vec::new(),
        };
        let entry = Arc::new(LocationEntry {
            cells,
            window,
            ons_basis,
            activation_basis,
            readout_basis,
        });
        let bytes = (entry.ons_basis.len() + entry.activation_basis.len()) * 4
            + entry.readout_basis.len() * 8
            + entry.cells.len() * 16;
        let mut cache = self.cache.lock().expect("cache lock");
        if cache.bytes + bytes <= CACHE_LIMIT_BYTES {
            cache.bytes += bytes;
            cache.entries.insert(key, entry.clone());
        }
        entry
    }

    /// The window the cortex decodes for a patch reading `cells` (`None`: the whole field).
    fn decode_window(&self, cells: &[usize]) -> Option<WindowRead> {
        let Decoder::Cortex(cortex) = &self.decoder else {
            return None;
        };
        if self.whole_field {
            return None;
        }
        let n = self.retina.n();
        let (rows, cols) = super::readout::cells_box(cells, n)?;
        let window = cortex.exact_window(rows, cols);
        let out_box = OutputBox {
            rows: [rows[0] - window.top, rows[1] - window.top],
            cols: [cols[0] - window.left, cols[1] - window.left],
        };
        let in_box = Window {
            top: rows[0],
            left: cols[0],
            height: rows[1] - rows[0] + 1,
            width: cols[1] - cols[0] + 1,
        };
        let local = cells
            .iter()
            .map(|&i| {
                in_box
                    .local_index(i, n)
                    .expect("a read cone lies in its box")
            })
            .collect();
        Some(WindowRead {
            window,
            out_box,
            local,
        })
    }

    /// Decodes the shows `members` (indices into `shows`, whose entries' windows share a size
    /// and a box) through the cortex, D on each show's window (its decoder on the box), and
    /// reads them into their rows of `out`.
    fn decode_cortex(
        &self,
        cortex: &Cortex,
        shows: &[Show],
        entries: &[Arc<LocationEntry>],
        members: &[usize],
        out: &mut [f64],
    ) {
        let (dim, n) = (self.decoder.dim(), self.retina.n());
        let len = self.readout.len(dim);
        let mut tape = TAPE.take().unwrap_or_default();
        tape.clear();
        let windows: Option<Vec<Window>> = members
            .iter()
            .map(|&i| entries[i].window.as_ref().map(|r| r.window))
            .collect();
        // One box for the batch: the caller groups shows by window size and box.
        let out_box = entries[members[0]].window.as_ref().map(|r| r.out_box);
        let v = match &windows {
            Some(w) if !entries[members[0]].activation_basis.is_empty() => {
                let pa = Self::summed(
                    shows,
                    entries,
                    members,
                    w[0].area(),
                    |e| &e.activation_basis,
                    |s| self.values(s),
                );
                cortex.record_decode_activation_windows(&mut tape, &pa, w, out_box)
            }
            _ => {
                let ons = if self.settings.noise_ratio == 0.0 {
                    Self::summed(
                        shows,
                        entries,
                        members,
                        n * n,
                        |e| &e.ons_basis,
                        |s| self.values(s),
                    )
                } else {
                    let shown = members.iter().flat_map(|&i| self.render(&shows[i]).1);
                    shown.collect()
                };
                let o = tape.constant_from([members.len(), 1, n, n], &ons);
                match &windows {
                    Some(w) => cortex.record_decode_windows(&mut tape, o, w, out_box),
                    None => cortex.record_decode(&mut tape, o).percept,
                }
            }
        };
        let percept = tape.value(v).data();
        let plane = percept.len() / members.len().max(1);
        if let Some(o) = out_box {
            let (h, w) = o.size();
            debug_assert_eq!(plane, dim * h * w, "a windowed percept is its box's");
        }
        for (s, &i) in members.iter().enumerate() {
            let e = &entries[i];
            let cells = e.window.as_ref().map_or(&e.cells, |r| &r.local);
            let rows = &mut out[i * len..(i + 1) * len];
            self.readout
                .read(&percept[s * plane..(s + 1) * plane], dim, cells, rows);
        }
        tape.clear();
        let idle = crate::budget::decode_tape_bytes(self.settings.decode_batch, (n * n) as f64);
        tape.pool().trim(idle as usize);
        TAPE.set(Some(tape));
    }

    /// The frames `(members × plane_len)` of shows `members`, each the sum of its entry's
    /// `basis` planes weighted by its class-plane `values`.
    fn summed(
        shows: &[Show],
        entries: &[Arc<LocationEntry>],
        members: &[usize],
        plane_len: usize,
        basis: impl Fn(&LocationEntry) -> &[f32],
        values: impl Fn(&Show) -> Vec<f64>,
    ) -> Vec<f32> {
        let mut out = vec![0f32; members.len() * plane_len];
        for (&i, o) in members.iter().zip(out.chunks_exact_mut(plane_len)) {
            let b = basis(&entries[i]);
            for (&v, plane) in values(&shows[i]).iter().zip(b.chunks_exact(plane_len)) {
                o.iter_mut()
                    .zip(plane)
                    .for_each(|(x, b)| *x += v as f32 * b);
            }
        }
        out
    }

    /// Class-plane values of a show's stimulus (the planes the cones read).
    pub(super) fn values(&self, show: &Show) -> Vec<f64> {
        let mut v = self
            .retina
            .class_values(&show.stimulus.to_grid(self.retina.grid()));
        v.truncate(self.retina.classes_read());
        v
    }

    /// The readouts of `shows` into `out (shows × readout length)`, for one rayon job.
    pub(super) fn percepts_job(&self, shows: &[Show], out: &mut [f64]) {
        let (dim, nn) = (self.decoder.dim(), self.retina.n() * self.retina.n());
        let len = self.readout.len(dim);
        let noise_free = self.settings.noise_ratio == 0.0;
        let entries: Vec<Arc<LocationEntry>> = shows
            .iter()
            .map(|s| self.location_entry(s.location))
            .collect();
        if noise_free && self.decoder.is_linear() {
            for ((show, entry), o) in shows.iter().zip(&entries).zip(out.chunks_exact_mut(len)) {
                o.fill(0.0);
                for (c, &v) in self.values(show).iter().enumerate() {
                    let basis = &entry.readout_basis[c * len..(c + 1) * len];
                    o.iter_mut().zip(basis).for_each(|(x, b)| *x += v * b);
                }
            }
            return;
        }
        if let Decoder::Cortex(cortex) = &self.decoder {
            // Shows whose windows share a size and a box are decoded together (the whole field
            // is one).
            let mut groups: BTreeMap<(usize, usize, Option<OutputBox>), Vec<usize>> =
                BTreeMap::new();
            for (i, e) in entries.iter().enumerate() {
                let key = e.window.as_ref().map_or((nn, 0, None), |r| {
                    (r.window.height, r.window.width, Some(r.out_box))
                });
                groups.entry(key).or_default().push(i);
            }
            for members in groups.values() {
                self.decode_cortex(cortex, shows, &entries, members, out);
            }
            return;
        }
        for ((show, entry), o) in shows.iter().zip(&entries).zip(out.chunks_exact_mut(len)) {
            let (act, ons) = self.render(show);
            let planes = self.linear_percept(&act, &ons, false);
            self.readout.read(&planes, dim, &entry.cells, o);
        }
    }
}
