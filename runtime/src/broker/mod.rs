//! The broker: a pure decision core (events in, actions out) and its live driver.
