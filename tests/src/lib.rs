//! Helpers for the end-to-end tests in `tests/tests/`: each test gets its own IPC
//! namespace and temporary directory.
