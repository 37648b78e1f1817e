//! Device drivers: the serial protocols of the SICK laser and the RFlex base.
