//! Closed-loop simulation of three cars with the firmware in the loop. Not written yet: tracked
//! in its own issue.
