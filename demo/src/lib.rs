//! `lewis demo`: the README's main job. The simulated robot runs the Robot Challenge
//! mission with the recorder on; a fault kills a provider on the way (the broker fails over
//! and the mission goes on); the recording is re-simulated with a fault at another time; a
//! few lines, a picture and a Rerun file say what happened.
//!
//! It owns the demo's story: which robot and script, when the fault strikes, what is
//! written where and what is printed. It decides nothing of a run itself: the launch runs
//! the robot, the sequencer judges the mission, replay re-simulates it.
