//! Progress bars with a rate and an ETA, shared by the subcommands.

use indicatif::ProgressStyle;

/// A bar labelled `label` showing position, rate and ETA.
pub fn style(label: &str) -> ProgressStyle {
    ProgressStyle::with_template(&format!(
        "{label:<6} [{{bar:30}}] {{pos}}/{{len}} {{msg}} {{per_sec}} eta {{eta}}"
    ))
    .expect("valid template")
    .progress_chars("=> ")
}
