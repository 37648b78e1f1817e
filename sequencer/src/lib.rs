//! Lewis sequencer: the mission script language of the paper, the finite state machine
//! of sub-task programs, and the supervisor's GUI.
