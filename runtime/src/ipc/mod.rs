//! IPC over iceoryx2: publish-subscribe of CDR bytes, commands, events, all under a namespace.
