//! A schema-driven decoder: any ros2msg schema text plus CDR bytes to a value tree.
