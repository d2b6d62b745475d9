//! The codecs a user picks by name (`cgv encode --codec`, Python's
//! `codec=`), each named for what its files store
//! ([`Representation`]), and how each sets the encoder's options: one
//! rule for the CLI and the Python package.

use super::{auto_corrections, auto_normal_correction, EncodeOptions};
use crate::error::{Error, Result};
use crate::format::{CodecKind, Representation};
use crate::solve::SolverKind;

/// A codec by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CodecChoice {
    /// `normal` or `predictive`, whichever measured better for the rate,
    /// grid and layers ([`auto_normal_correction`]).
    #[default]
    Auto,
    /// [`Representation::Normal`].
    Normal,
    /// [`Representation::Predictive`].
    Predictive,
    /// [`Representation::Conformal`]: the seed paper's H + λ, decoded by
    /// the paper's solver unless another is asked for.
    Conformal,
    /// [`Representation::Gv`].
    Gv,
}

/// Names accepted besides the codecs' own: `cgv`, the single name the
/// project's codecs had before they were told apart, is `auto`.
const ALIASES: [(&str, CodecChoice); 1] = [("cgv", CodecChoice::Auto)];

impl CodecChoice {
    pub const ALL: [CodecChoice; 5] =
        [CodecChoice::Auto, CodecChoice::Normal, CodecChoice::Predictive, CodecChoice::Conformal, CodecChoice::Gv];

    pub fn name(self) -> &'static str {
        match self {
            CodecChoice::Auto => "auto",
            CodecChoice::Normal => Representation::Normal.name(),
            CodecChoice::Predictive => Representation::Predictive.name(),
            CodecChoice::Conformal => Representation::Conformal.name(),
            CodecChoice::Gv => Representation::Gv.name(),
        }
    }

    /// The codec named `s` (or one of its aliases).
    pub fn parse(s: &str) -> std::result::Result<CodecChoice, String> {
        let own = CodecChoice::ALL.into_iter().find(|c| c.name() == s);
        own.or_else(|| ALIASES.iter().find(|a| a.0 == s).map(|a| a.1)).ok_or_else(|| {
            let names: Vec<&str> = CodecChoice::ALL.iter().map(|c| c.name()).collect();
            format!("unknown codec '{s}' (expected {})", names.join(", "))
        })
    }

    /// `opts` (their grid, rate and layers already set) made to encode with
    /// this codec; `solver`, if given, the decoder the file names as
    /// intended. Only the conformal codec's files can be read by the
    /// paper's solver: the others' corrections need the predictive one.
    pub fn apply(self, mut opts: EncodeOptions, solver: Option<SolverKind>) -> Result<EncodeOptions> {
        opts.codec = if self == CodecChoice::Gv { CodecKind::Gv } else { CodecKind::Cgv };
        opts.code_corrections = self != CodecChoice::Conformal;
        opts.corrections = auto_corrections(&opts.video, opts.grid, opts.video.fps);
        opts.normal_correction = match self {
            CodecChoice::Auto => auto_normal_correction(&opts.video, opts.grid, opts.video.fps, opts.layers),
            _ => self == CodecChoice::Normal,
        };
        opts.solver = match (self, solver) {
            (CodecChoice::Conformal, s) => s.unwrap_or(SolverKind::Paper),
            (_, None | Some(SolverKind::Predictive)) => SolverKind::Predictive,
            (_, Some(SolverKind::Paper)) => {
                return Err(Error::Argument(format!(
                    "the paper's solver reads H and λ alone, which only the conformal codec's files are made \
                     for; the {} codec's corrections need the predictive solver (use --codec conformal)",
                    self.name()
                )))
            }
        };
        Ok(opts)
    }
}

impl std::fmt::Display for CodecChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::h264::VideoSettings;

    #[test]
    fn each_name_reads_back_and_cgv_is_auto() {
        for c in CodecChoice::ALL {
            assert_eq!(CodecChoice::parse(c.name()), Ok(c));
        }
        assert_eq!(CodecChoice::parse("cgv"), Ok(CodecChoice::Auto));
        let e = CodecChoice::parse("paper").unwrap_err();
        assert!(e.contains("conformal") && e.contains("predictive"), "{e}");
    }

    #[test]
    fn each_codec_sets_what_its_files_store() {
        let base = EncodeOptions { video: VideoSettings { qp: 20, ..Default::default() }, ..Default::default() };
        let o = |c: CodecChoice| c.apply(base.clone(), None).unwrap();
        assert!(o(CodecChoice::Normal).normal_correction && o(CodecChoice::Normal).closed_loop());
        assert!(!o(CodecChoice::Predictive).normal_correction && o(CodecChoice::Predictive).closed_loop());
        let conformal = o(CodecChoice::Conformal);
        assert!(!conformal.closed_loop() && conformal.solver == SolverKind::Paper);
        assert_eq!(o(CodecChoice::Gv).codec, CodecKind::Gv);
        // QP 20 is inside the range where the normal layout measured better.
        assert!(o(CodecChoice::Auto).normal_correction);
        let coarse = EncodeOptions { video: VideoSettings { qp: 40, ..Default::default() }, ..base.clone() };
        assert!(!CodecChoice::Auto.apply(coarse, None).unwrap().normal_correction);
        // The predictive solver on H and anchors alone: the conformal file, decoded open loop.
        let open = CodecChoice::Conformal.apply(base.clone(), Some(SolverKind::Predictive)).unwrap();
        assert!(!open.closed_loop() && open.solver == SolverKind::Predictive);
        let e = CodecChoice::Normal.apply(base, Some(SolverKind::Paper)).unwrap_err().to_string();
        assert!(e.contains("--codec conformal"), "{e}");
    }
}
