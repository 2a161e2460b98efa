//! What a command's run says of its result; `main` turns it into the exit status.

/// Whether a run's result can be trusted; `main` exits 3 on [`Verdict::Untrusted`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// The run finished and nothing speaks against its result (warnings alone keep this).
    Trusted,
    /// The run finished but its result must not be trusted, for these reasons (one line each).
    Untrusted(Vec<String>),
}

impl Verdict {
    /// [`Verdict::Trusted`] when `reasons` is empty, else [`Verdict::Untrusted`].
    pub fn from_reasons(reasons: Vec<String>) -> Verdict {
        if reasons.is_empty() {
            Verdict::Trusted
        } else {
            Verdict::Untrusted(reasons)
        }
    }
}
