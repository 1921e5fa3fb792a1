//! One condition of a study: a perturbation term (or, in link studies, a viewpoint axis) and
//! the levels it takes. The type is the study file's (`run_format::study_file`).

pub use run_format::study_file::Vary;
