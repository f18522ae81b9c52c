//! `report.html` of a run folder: one self-contained page a browser opens offline. Every
//! picture and plot of the folder is embedded as a `data:` URI (base64), the page has no
//! script, no style sheet or font from elsewhere, and no link out.
//!
//! Sections, each present when the run wrote its files: the result (dimension, verdict, each
//! K's converged margin, held-out prediction error, the first step at each dimension); the
//! dimension over training (`dimension.svg`, paper Fig. 3.3); CMF-SIM's error curves with the
//! threshold (`cmf_sim_errors.svg`); Neural Scope beside the true colour (`pictures/scope.png`)
//! and the last class's own signal beside the truth's (`pictures/own_<class>.png`);
//! learned C beside the true mosaic, W beside the true DoG, P against the true positions,
//! with the invariants' numbers; the optic nerve signal; the loss; the learning rule's update
//! against backprop's gradient per bucket (`alignment.svg`); the settings
//! (`config.toml`). Written at the end of a run, after `summary.json`.

use crate::run::error::RunError;
use science::summary::Summary;
use std::fmt::Write as _;
use std::path::Path;

/// Name of the page in a run folder.
pub const REPORT_FILE: &str = "report.html";

/// The style sheet of the project's pages, inline.
pub const STYLE: &str =
    "body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;\
color:#222}h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:1.6em}\
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:left}\
figure{display:inline-block;margin:0.5em 1em 0.5em 0;vertical-align:top}\
figure img{max-width:100%;border:1px solid #eee}figcaption{font-size:0.9em;color:#555}\
.pair img{width:256px;image-rendering:pixelated}pre{background:#f6f6f6;padding:0.5em;\
font-size:0.8em;max-height:30em;overflow:auto}";

/// Writes `out/report.html` for the run whose summary is `summary`.
pub fn write(out: &Path, summary: &Summary) -> Result<(), RunError> {
    let html = render(out, summary);
    Ok(crate::io::write_atomic(
        &out.join(REPORT_FILE),
        html.as_bytes(),
    )?)
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                s.push(ABC[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// `&`, `<`, `>` and `"` as entities.
pub fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A `<figure>` embedding the file `rel` of the run folder, or nothing when it is absent.
fn figure(out: &Path, rel: &str, caption: &str) -> String {
    let Ok(bytes) = std::fs::read(out.join(rel)) else {
        return String::new();
    };
    let mime = if rel.ends_with(".svg") {
        "image/svg+xml"
    } else {
        "image/png"
    };
    format!(
        "<figure><img alt=\"{a}\" src=\"data:{mime};base64,{}\"><figcaption>{a} \
         (<code>{r}</code>)</figcaption></figure>\n",
        base64(&bytes),
        a = escape(caption),
        r = escape(rel),
    )
}

fn row(html: &mut String, name: &str, value: &str) {
    let _ = writeln!(
        html,
        "<tr><th>{}</th><td>{}</td></tr>",
        escape(name),
        escape(value)
    );
}

fn result_table(html: &mut String, s: &Summary) {
    html.push_str("<table>\n");
    let dimension = match s.dimension {
        0 => "undefined".to_string(),
        d => d.to_string(),
    };
    row(html, "colour dimensionality (CMF-SIM)", &dimension);
    row(html, "verdict", &s.verdict);
    for line in &s.cmf_sim_per_k {
        row(html, "", line);
    }
    for (d, step, secs) in &s.first_step_at_dimension {
        row(
            html,
            &format!("first {d}-D"),
            &format!("step {step} ({secs:.0} s)"),
        );
    }
    let steps = format!(
        "{} ({:.0} s, {:.1} ms/step{})",
        s.steps,
        s.wall_seconds,
        s.mean_step_ms,
        if s.resumed_at_steps.is_empty() {
            String::new()
        } else {
            format!("; resumed at {:?}", s.resumed_at_steps)
        }
    );
    row(html, "steps", &steps);
    row(
        html,
        "eye motion given to the cortex",
        if s.oracle_motion {
            "oracle (true shift)"
        } else {
            "estimated"
        },
    );
    if let Some([model, identity, gain]) = s.heldout_prediction {
        row(
            html,
            "held-out prediction error",
            &format!("{model:.4e} against {identity:.4e} for \"next frame = this frame\" ({gain:.1}× better)"),
        );
    }
    html.push_str("</table>\n");
}

fn invariants_table(html: &mut String, s: &Summary) {
    let Some(inv) = &s.invariants else {
        return;
    };
    let r = &inv.recovery;
    html.push_str("<table>\n");
    if let Some(c) = &r.c {
        let j = |v: &[f64], d: usize| {
            let p: Vec<String> = v.iter().map(|x| format!("{x:.d$}")).collect();
            p.join(" / ")
        };
        row(
            html,
            &format!("C recall by nearest class centre ({})", c.classes.join("/")),
            &j(&c.recall_nearest_centroid, 2),
        );
        row(html, "C d′ to the nearest other class", &j(&c.dprime, 1));
    }
    if let Some(w) = &r.w {
        row(
            html,
            "W kernel r, surround r",
            &format!("{:.2}, {:.2}", w.kernel_r, w.surround_r),
        );
        row(
            html,
            "W DC gain",
            &format!("{:.3} (true {:.3})", w.dc_gain, w.true_dc_gain),
        );
    }
    row(
        html,
        "P error after the affine gauge (cone spacings)",
        &format!(
            "{:.2} RMS, {:.2} median",
            r.p.position_error_rms_cones, r.p.position_error_median_cones
        ),
    );
    row(
        html,
        "Neural Scope RMSE (linear sRGB)",
        &format!("{:.3}", inv.scope_rmse),
    );
    html.push_str("</table>\n");
}

/// The page for the run folder `out`.
pub fn render(out: &Path, s: &Summary) -> String {
    let c = &s.config;
    let title = format!(
        "colorvision run: preset {}, cones {}, seed {}, {} steps",
        c.preset, c.cones, c.seed, s.steps
    );
    let mut html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>{t}</title><style>{STYLE}</style></head><body>\n<h1>{t}</h1>\n<p>{}</p>\n",
        escape(&out.display().to_string()),
        t = escape(&title),
    );
    html.push_str("<h2>Result</h2>\n");
    result_table(&mut html, s);
    html.push_str("<h2>Dimension over training</h2>\n");
    html.push_str(&figure(
        out,
        "dimension.svg",
        "dimension at each CMF-SIM measurement",
    ));
    html.push_str("<h2>CMF-SIM</h2>\n");
    html.push_str(&figure(
        out,
        "cmf_sim_errors.svg",
        "best error per wavelength for K primaries, with the threshold",
    ));
    html.push_str("<h2>Neural Scope</h2>\n");
    html.push_str(&figure(
        out,
        "pictures/scope.png",
        "percept (left) beside the true colour (right)",
    ));
    if let Some(own) = s.invariants.as_ref().and_then(|i| i.own_image.as_ref()) {
        html.push_str(&figure(
            out,
            &format!("pictures/{}", own.file_name()),
            &format!(
                "{c}'s own signal (what the other classes do not predict): the scene (left), \
                 the truth (middle), the percept's reading (right); held-out R² {r:.2}",
                c = own.class,
                r = own.held_out_r2
            ),
        ));
    }
    html.push_str("<h2>Learned C, W, P beside the truth</h2>\n<div class=\"pair\">");
    html.push_str(&figure(
        out,
        "pictures/learned_c.png",
        "learned cone types (C)",
    ));
    html.push_str(&figure(out, "pictures/true_mosaic.png", "true mosaic"));
    html.push_str(&figure(
        out,
        "pictures/w_kernel.png",
        "learned W beside the true DoG",
    ));
    html.push_str("</div>\n");
    html.push_str(&figure(
        out,
        "pictures/positions.svg",
        "learned positions (P) against the true ones",
    ));
    invariants_table(&mut html, s);
    html.push_str("<h2>Optic nerve signal and loss</h2>\n");
    html.push_str(&figure(out, "pictures/ons.png", "what the cortex receives"));
    html.push_str(&figure(out, "loss.svg", "training loss"));
    let cosines = crate::alignment_plot::cosines(&out.join("metrics.csv"));
    if !cosines.is_empty() {
        let means = crate::alignment_plot::mean_cosines(&cosines);
        let said: Vec<String> = (crate::alignment_plot::BUCKETS.iter().zip(means))
            .filter_map(|(b, m)| Some(format!("{b} {:.2}", m?)))
            .collect();
        html.push_str("<h2>The learning rule against backprop</h2>\n");
        html.push_str(&figure(
            out,
            "alignment.svg",
            &format!(
                "cosine of the rule's update with backprop's gradient per bucket, {} \
                 measurements (metrics.csv); mean {}",
                cosines.len(),
                said.join(", ")
            ),
        ));
    }
    html.push_str("<h2>Settings</h2>\n<pre>");
    html.push_str(&escape(&c.to_toml()));
    html.push_str("</pre>\n</body></html>\n");
    html
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc_4648() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), coded, "{plain}");
        }
        assert_eq!(base64(&[0xff, 0xfe, 0x00]), "//4A");
    }

    #[test]
    fn markup_in_text_is_escaped() {
        assert_eq!(escape("a<b & \"c\">"), "a&lt;b &amp; &quot;c&quot;&gt;");
    }
}
