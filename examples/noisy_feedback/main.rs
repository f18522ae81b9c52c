//! `colorvision` with one more learning rule, `noisy-feedback` ([`rule`]): the whole program,
//! its subcommands, `--config` files and sweeps, with the rule registered by one call.
//!
//! ```text
//! cargo run --release --example noisy_feedback -- train --preset quick --steps 600 \
//!     --config noisy.toml          # noisy.toml: learning_rule = "noisy-feedback"
//!                                  #             [rule]
//!                                  #             noise = 0.5
//! ```

mod rule;

fn main() {
    cortex::rule::register(rule::entry()).expect("noisy-feedback is a new name");
    colorvision::program::main()
}
