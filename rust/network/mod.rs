//! The spiking network (SPEC §3, docs/model.md). Filled in by the engine issue.
