//! The codecs a user picks by name (`cgv encode --codec`, Python's
//! `codec=`), each named for what its files store
//! ([`Representation`]), and how each sets the encoder's options: one
//! rule for the CLI and the Python package.

use super::{auto_corrections, auto_normal_correction, EncodeOptions};
use crate::error::{Error, Result};
use crate::format::Representation;
use crate::solve::SolverKind;

/// A codec by name: one of the representations, or `auto`, which picks
/// `normal` or `predictive`, whichever measured better for the rate, grid
/// and layers ([`auto_normal_correction`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CodecChoice {
    #[default]
    Auto,
    Named(Representation),
}

/// Names accepted besides the codecs' own: `cgv`, the single name the
/// project's codecs had before they were told apart, is `auto`.
const ALIASES: [(&str, CodecChoice); 1] = [("cgv", CodecChoice::Auto)];

impl CodecChoice {
    pub const ALL: [CodecChoice; 7] = [
        CodecChoice::Auto,
        CodecChoice::Named(Representation::Normal),
        CodecChoice::Named(Representation::Predictive),
        CodecChoice::Named(Representation::Conformal),
        CodecChoice::Named(Representation::Gv),
        CodecChoice::Named(Representation::Skinned),
        CodecChoice::Named(Representation::Vertices),
    ];

    pub fn name(self) -> &'static str {
        match self {
            CodecChoice::Auto => "auto",
            CodecChoice::Named(r) => r.name(),
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
        opts.representation = match self {
            CodecChoice::Auto if auto_normal_correction(&opts.video, opts.grid, opts.video.fps, opts.layers) => {
                Representation::Normal
            }
            CodecChoice::Auto => Representation::Predictive,
            CodecChoice::Named(r) => r,
        };
        if opts.representation == Representation::Skinned {
            opts.bones = opts.bones.or(Some(super::DEFAULT_BONES));
            // Tiny parts too move with the bones, on the grid by a tube:
            // the residual is small there as anywhere.
            opts.param.loose_max_vertices = 0;
        }
        opts.corrections = auto_corrections(&opts.video, opts.grid, opts.video.fps);
        opts.solver = match (opts.representation, solver) {
            (Representation::Conformal, s) => s.unwrap_or(SolverKind::Paper),
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

    const NORMAL: CodecChoice = CodecChoice::Named(Representation::Normal);
    const PREDICTIVE: CodecChoice = CodecChoice::Named(Representation::Predictive);

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
        assert!(o(NORMAL).normal_correction() && o(NORMAL).closed_loop());
        assert!(!o(PREDICTIVE).normal_correction() && o(PREDICTIVE).closed_loop());
        let conformal = o(CodecChoice::Named(Representation::Conformal));
        assert!(!conformal.closed_loop() && conformal.solver == SolverKind::Paper);
        assert_eq!(o(CodecChoice::Named(Representation::Gv)).codec(), crate::format::CodecKind::Gv);
        // QP 20 is inside the range where the normal layout measured better.
        assert!(o(CodecChoice::Auto).normal_correction());
        let coarse = EncodeOptions { video: VideoSettings { qp: 40, ..Default::default() }, ..base.clone() };
        assert!(!CodecChoice::Auto.apply(coarse, None).unwrap().normal_correction());
        // The predictive solver on H and anchors alone: the conformal file, decoded open loop.
        let open =
            CodecChoice::Named(Representation::Conformal).apply(base.clone(), Some(SolverKind::Predictive)).unwrap();
        assert!(!open.closed_loop() && open.solver == SolverKind::Predictive);
        let e = NORMAL.apply(base, Some(SolverKind::Paper)).unwrap_err().to_string();
        assert!(e.contains("--codec conformal"), "{e}");
    }
}
