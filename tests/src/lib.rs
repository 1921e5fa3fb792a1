//! Cross-process integration tests (see `tests/`); this library is intentionally empty.
