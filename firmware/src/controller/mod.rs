//! The control step: one set of inputs in, one acceleration command out.
//!
//! # The certificate: a split of the three-car game at one braking level
//! The table is a [`Game::ThreeCarSplit`](table_format::Game::ThreeCarSplit) table. For the ego's
//! braking level `beta` (the table's `-ego.min`) a state `(gap_leader, leader_speed, gap_follower,
//! follower_speed, ego_speed)` is **certified** when
//! - the *front value* `F(z) = front_value(gap_leader, leader_speed, ego_speed)`, the smallest
//!   gap to a leader braking as hard as its model allows while the ego brakes at `beta`, in
//!   closed form ([`table_format::front`]), exceeds `front_margin`, and
//! - the *rear value* `W(z)`, the table's value at `(gap_follower, follower_speed, ego_speed)`
//!   less its error bound, exceeds `rear_margin`. `W` is the stationary (infinite-horizon)
//!   value of the rear game in which the ego's acceleration anywhere in the band
//!   `[-beta, a_max]` is adversarial: it bounds the rear gap from below for as long as the
//!   ego keeps its command in the band, whatever the command is.
//!
//! # The law, and why it keeps a certified state certified
//! Every command is in the band `[-beta, a_max]`, in every mode (the emergency authority's
//! answers to an uncertified front aside, below), so the rear half needs no decision: it is a
//! property of the band, proven for the table itself, cell by cell, by `solver verify` (below). The
//! front half decides the command. The nominal ACC law (the `law` module, which knows nothing of
//! the certificate but its steady-following gap) proposes `u`; the look-ahead computes
//! `front_value` for `u` held one period `h`, then the **braking ramp** from `u` down to `beta`
//! (plus the delays, see below). That is the smallest front gap over every leader behaviour, the
//! period included, and every state the period can reach has a front value at least as large (the
//! reached state's worst case is one of the behaviours the look-ahead took the minimum over). So if
//! the look-ahead exceeds `front_margin` the law's command is applied ([`Mode::Nominal`]);
//! otherwise ([`Mode::Override`]) the gentlest braking between the ramp's floor and the refused
//! command that the look-ahead passes (a secant step, `table_format::front::least_braking`), or,
//! when none does, the ramp itself. Either way a certified state's front value stays above
//! `front_margin`. No monotonicity of the table is used: the rear value is a property of the band,
//! and the front value is exact.
//!
//! # The braking ramp: the jerk limit inside the certificate
//! ISO 15622 limits an ACC's braking jerk (2.5 m/s^3 at and above 20 m/s, [`crate::iso15622`]).
//! A certificate that assumes braking at `beta` at once would have to jump there, the jab a
//! driver feels. So the actuator model has the ramp in it: the controller never lowers its
//! command faster than `brake_jerk` (default 2.5 m/s^3, so every certified command keeps
//! ISO 15622's jerk limit at every speed), and the front value is evaluated with the ramp in
//! closed form (`table_format::front`: a hold, then `max(r - j s, -beta)`). A **ramp** is a
//! start `t_b` and a reference `r`: from `t_b` every command is at most `max(r - j (t - t_b +
//! h), -beta)` (the staircase of held commands lies below the continuous ramp). The ramp is
//! *committed*: once nothing passes the look-ahead, the ramp started where the last passing
//! command's look-ahead said it would (at `now`, from the last command) and it keeps its start
//! and reference while it runs, so that the argument below holds; a command that passes ends it.
//! The price: the certificate's steady-following gap grows by about `v (u + beta) / (2 j)`, at
//! 30 m/s from 76 m to 97 m (`host-tests gap-policy`, docs/closed-loop.md); the override starts
//! earlier, not harder. `Config::bang_bang()` is the paper's policy instead: no ramp (`brake_jerk =
//! f32::INFINITY`) and braking at `beta` whenever the look-ahead refuses.
//!
//! **Emergencies.** A state whose front value or speed headroom is not certified at the error
//! box's worst corner gets the ramp too when a step since the last engagement or cut-in was
//! certified or issued a command that passed the look-ahead, and the box's best corner, with the
//! ego following the ramp's commands at once, still is (a certified measurement or a passed
//! look-ahead certifies the true state, and the ramp keeps it certified: measurement noise
//! moves the corner, not the truth; the best corner bounds the true value from above, so where
//! it fails the truth is not certified); otherwise (an engagement into an uncertified state, a
//! cut-in, a leader beyond its model) the command is the emergency answer: a braking at once as
//! hard as the leader's worst case needs. Where `beta` at once keeps that worst case (at the error
//! box's worst corner, through the dead time and the lag) above the front margin, it is the
//! gentlest level between the committed ramp's command and `beta` that does (a secant in `1 /
//! level`, checked; at least the brake lights' command): a cut-in 55 m ahead at the ego's 20 m/s
//! gets about 2.8 m/s^2, not 3.5. Where `beta` does not, it is harder, under the emergency
//! authority (below). With no ramp under way the step starts one through the answer: the next
//! step's front value has the same hold, then the continuous ramp the certificate argues with,
//! which starts `brake_jerk h` (0.05 m/s^2) gentler than the answer and brakes harder from its
//! first period on, so it is the answer's less a few micrometres, or more. With a ramp under way
//! the answer is at or below its command, and the ramp is kept. Either way the next step judges the
//! state again. Every period of it is flagged in [`Command::emergency`] with the takeover request,
//! as is any command that drops faster than ISO 15622's jerk limit while the car may be moving (not
//! where its measured speed's error box reaches zero: a harder hold moves a car at rest nothing).
//!
//! # Emergencies: the emergency authority, bought from the follower
//! The vehicle declares a second braking, its full one ([`CertificateConfig::emergency`]:
//! 8 m/s^2 built up at 12 m/s^3 by default, a dry road), within its envelope. It is used only
//! in the emergency answer, and only where braking at `beta` at once cannot keep the leader's
//! worst case (at the error box's worst corner, through the delays) above the front margin:
//! then the command is the gentlest level between `beta` and the full one whose braking does
//! (the ego's acceleration held at what is pending through the dead time and the lag, then
//! building up at the declared jerk: the slower of the two), or the full level where none
//! does, found by a secant in `1 / level` and checked; commanded at once, flagged an
//! emergency. The follower behind sells that braking: the level is lowered to the hardest
//! (to 0.02 m/s^2, [`table_format::rear::hardest_clearing`]) that
//! keeps [`table_format::rear::rear_gap_after`] above `rear_margin` at the worst corner of the
//! follower's measurement box at its time `t_f`, for a follower that keeps accelerating (at
//! most at its IDM's largest acceleration) until its reaction time
//! ([`EmergencyDeclaration::follower_reaction_time`], 1.15 s: UN R157's careful driver) after the
//! ego's brake lights are on for sure, then brakes at its clip's hardest (6 m/s^2 on the
//! deployed table), the ego braking at most at that level from now on (harder braking since
//! `t_f` taken as held for good, or as the speed it can cost beyond that level through the
//! declared lag, whichever bounds better: `RearCorner::gap_after`). The
//! lights are on from [`table_format::rear::lights_on_within`] after a run of commands at or
//! below the vehicle's declared lights' command began ([`EmergencyDeclaration::lights_command`],
//! -1.5 m/s^2 by default; the lights are on for sure once the acceleration is below
//! [`EmergencyDeclaration::lights_deceleration`]'s negative, -1.3 m/s^2), while it lasts (the
//! dead time and lag from what is pending); the
//! reaction counts from there, so a follower close behind allows more as the braking goes on.
//! A run counted from its commands at the lights' command alone lights them 0.6-0.7 s after it
//! starts, whatever it brakes; a braking at or below the band's floor lights them within a few
//! tenths. So a command `c` at or below the band's floor holds itself: where the on-time for
//! commands at or below `c` from now is earlier than the run's, it becomes the run's, and every
//! command until then is at most `c` (`LightsHold`, enforced in [`Controller::step`] whatever
//! the mode, and argued with by the emergency answer's rear check: the level the leader's
//! worst case wants with its own hold, a gentler one with the band's floor's, which lights the
//! brakes no sooner).
//! Holding a braking the rear check passed with is inside what that check proved (the ego
//! braking at most at its level from the measurement on), and braking harder never lowers the
//! front's value.
//! Where it allows nothing beyond `beta` the answer is `beta`: the car ahead is not bought with
//! the car behind. The lights go off again (a command above the lights' command at the end of
//! a run that went below the band, or any while that braking may still act) only where the
//! follower allows it: where, its reaction starting again when they next come on, braking at
//! `beta` then keeps the same check (the command held a period, then the braking ramp down to
//! the lights' command lighting them); else the command follows that ramp from the last
//! command, the lights come on, and the follower, reacting, falls back
//! (`emergency::release_allowed`: the authority kept until a lower one certifies,
//! `table_format::authority`'s rule).
//!
//! This is an answer, not a certificate: the front is outside the model already. What follows
//! it is stated, not assumed away: the rear table's value holds only while the ego brakes
//! within the band, so a follower measurement that the braking's effect may reach (taken up to
//! a period, the dead time and ten lag time constants after the last command below the band:
//! the lag then passes on `e^-10` of the excess, 2e-4 m/s^2) is not used for the rear half
//! ([`Fault::AfterEmergencyBraking`], [`Mode::Uncertified`], the front still enforced); the
//! ego's speed interval at a track's time takes the emergency level as its lowest acceleration
//! for as long. The follower model credits its whole braking once it has reacted to any
//! braking; a driver who answers a gentle braking gently and is then surprised by a harder one
//! is outside it.
//!
//! # Two authorities (opt-in): the braking the follower allows, inside the certificate
//! With [`CertificateConfig::authorities`] set to [`Authorities::Two`] the certificate is
//! `table_format::authority`'s, through the delays and the error boxes: a state is certified by
//! a [`Braking`] in force `B` (a level and a build-up) when the front value along `B`'s ramp
//! (the committed ramp above, at `B`'s jerk down to `B`'s level) exceeds `front_margin`, the
//! rear value of `B` against the follower that reacts `follower_reaction_time` after the brake
//! lights (`table_format::rear::rear_gap_after` at the worst corner of the kept follower
//! measurement's box at its time, the ego braking at most at `B`'s level, an earlier harder
//! braking counted as above) exceeds `rear_margin`, and the speed headroom is not negative. The
//! rear table is not used (the follower's model is the reacting one); its header gives the models.
//! - **The look-ahead** of a command `u` is argued along the emergency authority's build-up at
//!   the hardest level from `beta` to the emergency level that the follower allows when `u` is
//!   held a period and that ramp from `u` lights the brakes
//!   (`authorities::look_ahead_braking`, [`table_format::rear::hardest_clearing`] to 0.02 m/s^2);
//!   where it allows not even `beta`, at the hardest of four gentler levels down to the lights'
//!   command's (3.0, 2.5, 2.0 and 1.5 m/s^2 by default, `authorities::gentler_than_band`, each
//!   with the lights' on-time of its own ramp or a later one), as the rule's brakings go down
//!   to `table_format::authority::LEAST_LEVEL`: the front then needs more room, which the
//!   look-ahead checks and the law's gap keeps;
//!   or along the comfort band's braking (`beta` built up at ISO 15622's jerk limit at the
//!   ego's speed, at least `brake_jerk`: `Controller::comfort_jerk`, so that following its ramp
//!   is no emergency) where its front passes and
//!   the rear clears with its own, slower, lights, and where the rear allows not even `beta`,
//!   along the gentler level found, built up at that jerk, where the same holds: a command
//!   that passes names the braking it
//!   passed with, which is in force from then on. One level serves every command up to the one
//!   it was found for (a gentler command lights the brakes no later), so the command is capped
//!   there, as by the speed: where the follower allows nothing after the law's proposal, the
//!   level is sought for the last command, then for the comfort band's step down from it, then
//!   for the lights' command. A command braking harder than the level does not pass. The
//!   follower's reaction is counted from when the lights come on along that ramp, or, for a
//!   command that keeps a lights' run going (at or below the lights' command, or, once the
//!   run's own commands have lit the brakes, below the lights' deceleration's negative), from
//!   the on-time the run's own commands bound where that is earlier: its reaction has then been
//!   running, as for the braking in force (not from an on-time a look-ahead argued with along
//!   its ramp, which holds only while the commands follow it).
//! - **The comfortable way to the lights**: where the proposal passes, but a follower closing
//!   on the ego would allow not even `beta` by the time ISO 15622's jerk limit brought the
//!   command down to the lights' command (`authorities::lit_in_time`: the look-ahead's rear
//!   check with the follower's box carried that long at its relative speed), the command goes
//!   down that way now (capped at `last - jerk_limit h`, at least the lights' command), and
//!   leaves it only for a proposal that leaves a second to spare: a prediction for comfort
//!   (the look-ahead that passed covers the lower command), so that the lights come on
//!   without the jump to the lights' command that the look-ahead would otherwise need later.
//!   Once there, while the run's own commands have not lit the brakes for sure, the way goes
//!   on down at the same jerk, no harder than the look-ahead's level or the band's floor
//!   (`Controller::way_down_past_the_lights`): held at the lights' command the actuator
//!   only nears the lights' deceleration through its lag, and where a follower closed
//!   meanwhile until no level cleared, the command followed the ramp of the braking in force,
//!   at the emergency authority's build-up.
//! - **Keeping the lights**: a proposal above the lights' command ends a lights' run, and the
//!   follower's reaction starts again when the lights next come on; once the run's own
//!   commands have lit the brakes for sure, only one at or above the lights' deceleration's
//!   negative does (`emergency::keeps_lights_run`: through a first-order lag the acceleration
//!   stays below -1.3 m/s^2 under commands all below it). Where the follower would
//!   then allow not even `beta` (`emergency::release_allowed`, the band's rule for ending a
//!   run: the proposal held a period and `authorities::RELEASE_SPARE_US` (0.2 s) more, the
//!   lights back along the comfort band's ramp), nor a gentler level a look-ahead argues
//!   with at which the front certifies, the proposal is the gentlest command that
//!   keeps the run instead (-1.35 m/s^2 in a lit run, else the lights' command), which the
//!   look-ahead checks as any other. For `authorities::RELEASE_WATCH_US` (1 s) after
//!   a run ended, every proposal that keeps the lights dark is asked the same, and where it
//!   fails goes down the comfortable way to the lights' command: the law's proposals near a
//!   stop hover above the lights' command for several periods. Comfort choices (a run ended
//!   under a closing follower made the next look-ahead fail and the command follow the
//!   emergency authority's ramp), not bounds: they only lower the proposal the look-ahead
//!   then checks.
//! - **A stop behind a follower**: the law plans a stop behind a stopped car harder than the
//!   lights' command by a margin (`Controller::stop_deceleration`), so that the lit run the
//!   closing follower does not let end brakes as the plan does, and the car halts at the
//!   standstill gap rather than where the run's braking took it (a comfort choice in the law:
//!   the look-ahead checks its proposals as any other).
//! - **The override** grades its braking between the refused command and the comfort band's
//!   floor reached at ISO 15622's jerk limit (`last - jerk_limit h`, at least `-beta`); where
//!   nothing passes, the command follows the ramp of the braking in force (an emergency, by the
//!   jerk check, where that is the emergency authority's).
//! - **Why it is invariant**: as for the band, with `B` in place of `beta`: a passed look-ahead
//!   certifies the state a period on along the braking it names (the front as above; the rear
//!   because the ego brakes at most at that level from then on and the lights come on no later
//!   than it argued), and along `B`'s own ramp the front value does not decrease and the rear
//!   value with the lights' clock does not decrease while they stay on (`table_format::rear`).
//!   The lights are counted from a run of commands that keep it
//!   (`emergency::keeps_lights_run`), or from the earlier time the certificate last argued
//!   with while the commands stay under its ramp.
//! - **The law's steady gap** is the certificate's with the braking the follower allowed the
//!   last look-ahead ([`Controller::allowed_braking`]): a close follower makes the car keep more
//!   room ahead.
//! - **Engagement**: in standby the braking in force is the one a look-ahead from what the
//!   actuator is doing finds, and the engagement is judged by its certificate. A certified
//!   engagement is taken only where the follower leaves the first engaged commands a
//!   comfortable way (`authorities::engages_comfortably`): the look-ahead would not send them
//!   down the comfortable way to the lights at once, or, where it would, the level the
//!   follower allows with the lights lit along that way (ISO 15622's jerk, not the emergency
//!   authority's build-up) still certifies the front. Elsewhere the engaged steps would go
//!   down that way until their look-ahead failed and then jump to the lights' command within
//!   0.12 s, an emergency the driver did not ask for; the engagement is refused
//!   ([`DriverError::NeedsEmergencyBraking`]). A prediction for the driver, argued from what
//!   the engaged steps may read (the actuator's report read again at its error's other end,
//!   the way starting two periods on), not a bound: the engaged steps keep their own
//!   certificate.
//! - **The commands since the follower's measurement** are credited where they are known: the
//!   ego's acceleration was at least the least command issued since then (a lag averages the
//!   commands in force; the commands older than its five time constants, down to the harder of
//!   the leader's declared braking and the envelope's least command, weigh at most `e^-5`:
//!   `Controller::least_issued_since`), so the rear
//!   check's closed form also takes the ego as braking at the level from the measurement, but
//!   faster and further back by what it did not brake until now
//!   (`emergency::RearCorner::gap_after`, the larger of the values). Only the commands issued
//!   are credited, not the commands to come: a later step may command anything down to the
//!   level, and the actuator may be instant. In steady following at 30 m/s behind a follower 1 s
//!   back, tracks 130 ms old, the level the follower allows rises from 4.05 to 4.23 m/s^2 once
//!   the commands reach back 1.75 s (`the_commands_issued_since_the_measurement_are_credited`).
//!
//! What it does not do yet: credit the ego's braking harder than its level since a measurement
//! below `beta` (the command history keeps its largest command, so the held and owed bounds
//! take the ego's braking since a follower measurement as hard as `beta` or the emergency's
//! level, whatever level the look-ahead argues with); credit the commands to come (a braking
//! ramp the commands keep to would be worth as much again: `host-tests gap-policy`'s levers);
//! move off from standstill with a follower at the IDM's jam distance behind (the
//! follower's model lets it accelerate blind until it sees the lights, and no braking
//! certifies that: `table_format::rear`'s module docs have why neither an IDM follower's speed
//! cap, with the declared errors, nor a committed move-off, against this follower, does, and
//! docs/closed-loop.md the figures), so in stop and go the car is held, by the emergency
//! authority's ramp; and
//! leave a lit run where the follower would then allow not even the gentlest level a
//! look-ahead argues with (the lights' command's, 1.5 m/s^2): at 8-10 m/s with a follower
//! 1-1.5 s behind the car is brought to a standstill the comfortable way, with no car ahead
//! (the scenario suite's cruise on a 10% grade at 20 mph), and behind a leader that draws
//! away, a fixed-gap IDM follower closes as the speeds fall until the car stops with it at
//! the jam distance behind and is held there (docs/closed-loop.md has the closed-loop
//! figures).
//!
//! # Delays: the measurements' age, the actuator's dead time and lag
//! The configuration declares the actuator's dead time `D` (a command acts `D` after it is
//! issued, at most 100 ms) and the time constant `tau` of its first-order lag (at most 0.3 s);
//! a track of any age is argued from its time (below: aging and lost tracks), the ego's speed
//! up to `stale_periods` periods old. The front is argued from the
//! leader track's measurement time `t_m`, not from now: the front value is a minimum over
//! every leader behaviour from `t_m` on, so what the leader did since is covered. The ego's
//! speed at `t_m` comes from its own measurement, moved to `t_m` within the accelerations the
//! ego can have had in between (the highest speed for the ego, the lowest for the leader).
//!
//! The ego's acceleration is bounded through the commands the controller has issued, which it
//! keeps (a sliding-window maximum back to the oldest kept measurement, less `D` and `5 tau`):
//! `pending` is the largest command issued since `t_m - D - 5 tau`, plus what older commands
//! can still pass through the lag (at most `e^-5` of the band's width). Where the query reaches
//! back before the controller's first command (an engagement, a cancel or a clock jump less
//! than `D + 5 tau` ago) it is also the largest reported state plus its error
//! ([`Inputs::ego_acceleration`]: the engagement knows what the car is doing) since a report at
//! or before `t_m`, kept as the commands are, or the band's top where a report is missing or
//! the reports do not reach back that far. Not the latest report: after an engagement the
//! actuator brakes harder with every period, and at an older measurement's time it was
//! accelerating more than it is now. Between two reports the actuator's acceleration is
//! assumed to be at most the larger (a first-order lag moves monotonically toward a held
//! demand). A ramp `(t_b, r)` seen from a
//! time `t_0` through the delays is a hold of `max(pending, r_0)` for `max(t_b + D - t_0, 0) +
//! tau`, then the ramp from `r_0 = r - j max(t_0 - t_b - D, 0)`: the commands form a
//! non-increasing profile, whose speed is a concave function of time, and a first-order lag
//! averages it over a delay of mean `tau` (Jensen's inequality; `table_format::front`, property
//! test `bounds_a_ramp_through_the_delays`). So the **certified front value** is `front_value`
//! at the state of `t_m` through the committed ramp: the one under way, or one starting now from
//! the last command. The **look-ahead** of a command `u` is the ramp from `u` starting at `now +
//! h`, with a hold of `max(pending, u + tail)`, `tail` the lag's `e^-5` of the band's width (the
//! next step's `pending` is `u + tail` when `u` is the largest command). Why it is invariant: at
//! the next step the certified value's ramp is the one the look-ahead assumed (a new ramp from `u`
//! at `now + h`), or the same ramp under way, with a `pending` no larger, from a later state that
//! one of the behaviours the look-ahead took the minimum over has reached; so it is at least the
//! look-ahead's value. The step is assumed to come every period: a late step holds a command longer
//! than the look-ahead assumed (within [`MAX_STEP_GAP_PERIODS`] it is not a fault; a board's timer
//! interrupt keeps the period).
//!
//! # The ego's speed: kept in the domain, not assumed
//! The rear value is the rear game's value over speeds in `[0, max_speed]`, so a certified
//! state must stay inside that range, and the ego's speed is the firmware's to keep there: no
//! human model bounds it. The **speed headroom** of a state is `max_ego_speed` less the
//! highest speed the ego can reach before the committed ramp takes its acceleration below zero:
//! from its measurement at `t_e`, `ego_speed + max(hold, 0) response + max(r_0, 0)^2 / (2 j)`
//! with the ramp's profile seen from `t_e`. A certified state has a headroom of zero or more
//! ([`Certificate::is_certified`]). The look-ahead caps a command `u` to the largest whose ramp
//! from `now + h` keeps that peak within `max_ego_speed` (a bisection: the peak is
//! non-decreasing in `u`), and when even the ramp's floor breaks it, nothing passes and the
//! ramp goes on. Why it is invariant: as for the front value. The law's set speed is held
//! below the domain's top by three of the ego speed's errors and 0.1 m/s (`SET_SPEED_ROOM` has
//! the derivation), so that cruising never leans on the cap.
//!
//! **With two authorities the speed has its own ramp.** The braking in force's ramp is the
//! emergency authority's build-up (12 m/s^3 by default), past ISO 15622's jerk limit, and the
//! speed needs no such haste: no human drives it. So the headroom is argued along the
//! *speed's ramp*, at the slowest authority's jerk (the comfort band's 2.5 m/s^3,
//! `Controller::speed_jerk`), kept apart from the braking ramp: while the commands fit the
//! cap it is the last command's from now (the cap's look-ahead is then the next state's
//! headroom); from a command that does not fit, the ramp goes on from its start, through that
//! command (reference `c + j h`, as the braking ramp), and every command until one fits is at
//! or below it: the cap's low end is the speed ramp's floor, not the braking ramp's. Standby
//! argues an engagement along the ramp from what the actuator may be doing (its report plus
//! the report's error) and keeps that ramp, so the first engaged step goes on from it rather
//! than restarting from its own period's report, whose error may read higher than the truth
//! (a command above the true acceleration raises it). Invariance is the band's argument at
//! that jerk: along one ramp, with the commands at or below it and the actuator monotone, the
//! bound `ego_speed + max(hold, 0) response + max(r_0, 0)^2 / (2 j)` never rises. The braking
//! ramp, the look-ahead's level and the lights judge such a command as any other (it passes
//! their look-ahead or the braking ramp takes it lower), so the front and the rear keep their
//! own argument; a lower command keeps the speed's. The loop's judge
//! (`Controller::certificate_with_actuator_and_lights`) takes the speed along the same ramp. So
//! the ego speed's error switching corners near the top costs a step down the speed's ramp,
//! within ISO 15622's jerk limit, not an emergency (`host-tests/tests/scenarios.rs`,
//! `the_speed_near_the_domains_top_is_no_emergency_with_two_authorities`).
//!
//! # The driver's controls
//! Set speed, time-gap setting, engage (SET), cancel and resume arrive through
//! [`Controller::request`] or [`Inputs::driver`] (CAN frame `0x140`, [`crate::can`]). They change
//! the driver's state only: the command history stays, so a new set speed brings no jab. A
//! cancel puts the controller in [`Mode::Standby`] (it keeps observing the tracks) and forgets
//! the commands, which the actuator's reported state covers at the next engagement. In standby
//! the certificate of the measured state is evaluated every period as an engaged step would,
//! and carried in the command's margin; an engagement (SET or resume) is taken only where it is
//! positive, and refused otherwise with its reason ([`DriverError::NotCertified`],
//! [`DriverError::CertificateUnknown`]): an engagement into an uncertified state would leave the
//! certificate nothing to keep. With two authorities one the follower leaves no comfortable
//! way to brake is refused too ([`DriverError::NeedsEmergencyBraking`], above: engagement).
//!
//! # The domain
//! The rear table covers `gap_follower` up to its last breakpoint, and speeds in
//! `[0, max_speed]`. A follower farther back than the grid (or none: a gap of `+inf`) is safe
//! until it crosses the grid's last gap, where its value is at least the smallest value on that
//! face of the grid, computed once when the table is loaded: that is its rear value. A leader
//! farther than any gap (or none) has an infinite front value. A measured speed of a human
//! slightly below zero is taken as zero (a slower follower and a faster leader are never
//! worse).
//!
//! **The rear state at one time.** The rear value is argued at the follower track's time
//! `t_f`: from a certified state at `t_f` the rear is safe for ever while every command is in
//! the band, whatever came after. The follower's speed is `ego_speed - rel_speed` with the
//! ego's speed *at `t_f`*, which its own measurement at `t_e` gives only within the
//! accelerations possible in between: `[ego - pending dt, ego + beta dt]` for an older track,
//! `[ego - beta dt, ego + pending dt]` for a newer one. So the rear value is the table's least
//! value over the box of those ego speeds and the follower speeds that go with them, held in
//! the human's `[0, max_speed]` ([`Table::least_over_box`]: exact for the multilinear
//! interpolation, one lookup when the times agree, at most `8^3` points with
//! [`table_format::BOX_INTERIOR`] breakpoints inside).
//!
//! An ego or follower faster than `max_speed` at that time, or a follower gap below the grid,
//! is outside the domain: [`Fault::OutsideDomain`], [`Mode::Uncertified`]. Only the rear half
//! is unknown there: the command is the nominal law under the same speed cap and front
//! look-ahead as in the domain, so the front override still acts. The
//! nominal law's set speed (30 m/s by default, below the table's 35) and the cap bring a fast
//! ego back into the domain, and its braking, like every command's, is at most `beta`, which
//! spares the follower: a rear table certifies nothing unless the follower can out-brake the
//! band (measured: with the follower's braking equal to `beta` the rear value's plateau is
//! -0.99 m, docs/numerics.md).
//!
//! # Measurement error, aging and lost tracks, cut-ins
//! The sensors' error is bounded and declared in [`Config::sensors`] ([`crate::sensing`]): every
//! measurement stands for the box of true values its error allows.
//! - **Front**: the front value is evaluated at the box's worst corner: the least gap, the
//!   slowest leader (the ego's lowest speed at `t_m` plus the least range rate) and the fastest
//!   ego. It is non-decreasing in the gap and the leader's speed and non-increasing in the ego's
//!   speed ([`table_format::front`]'s property test
//!   `the_error_boxs_worst_corner_is_its_least_value`), so that corner is the least value over the
//!   box; the leader's speed is `ego + range_rate`, and taking each at its own worst end covers the
//!   pair (conservative by the ego's error twice). The speed headroom and cap take the ego at its
//!   highest.
//! - **Rear**: the table's exact least value over the box (gap interval, the ego's speed at
//!   `t_f` within its error and its possible change since, the follower's with it and the
//!   range-rate error), [`Table::least_over_box`], the multilinear interpolant's minimum over the
//!   candidates (box ends and breakpoints inside), at most [`table_format::BOX_INTERIOR`]
//!   breakpoints per axis. Why at run time and not in a table eroded at compile time: the box
//!   depends on the track's age, known only at run time (an eroded table must take its worst);
//!   one table serves every declared sensor; the minimum is exact, not a second bound; and it is
//!   computed once per follower measurement (below). The share of measured rear states that
//!   pass with the declared error and with exact sensors is measured by `solver verify`
//!   (docs/certificate.md); every passing measurement's box lies in cells the proof covers.
//!   The worst control step's cost on the Cortex-M4F, against its budget of 20,000
//!   instructions, is measured on QEMU (docs/board.md).
//! - **Aging**: a measurement is argued from its own time, so its age is inside the argument.
//!   The last plausible leader measurement is kept with the interval of the ego's speed at its
//!   time (from the kept ego measurement nearest it); its look-ahead's response runs from then,
//!   so it grows with the age and the car slows as the track ages. The follower's rear value is
//!   computed once per measurement and kept: from a certified rear state at `t_f` the rear is
//!   safe for ever while every command is in the band, whatever the track's age. An invalid or
//!   implausible measurement is a missed refresh: the last good one goes on aging. The command
//!   history is kept back to the oldest kept measurement (merged, never under-stated, when it
//!   fills), so `pending` is known at any age.
//! - **Lost**: beyond `sensors.max_track_age_us` (1 s by default), the certified fallback: the
//!   minimum-risk deceleration under the front half of the last good leader measurement
//!   (braking harder, up to beta, when the leader's worst case since then needs it), the rear
//!   kept by the band; [`Mode::MinimumRisk`] with the fault and a margin. A track that comes back
//!   is a new measurement: its certificate is evaluated and its look-ahead decides before the
//!   nominal law resumes. Each command reports the tracks' states ([`TrackState`]), on CAN too.
//! - **Cut-ins**: a leader measurement whose range is below the least the last track's vehicle
//!   can have closed to is a new vehicle ([`TrackState::New`], [`Event::NewLeader`]). It is used in
//!   the period it arrives; where its front value is below the margin no command passes the
//!   look-ahead (it is non-increasing in the command) and the command is the emergency answer
//!   (above: as hard as the leader's worst case needs), with the takeover request
//!   ([`Command::takeover`]). A cut-in is outside the model: the certificate
//!   cannot promise what follows, only the best answer.
//!
//! # Faults and the minimum-risk manoeuvre
//! A table that does not parse, is not a split table, whose band does not fit the vehicle's
//! [`Envelope`] or that carries no complete `solver verify` record for the configured
//! `rear_margin`, a configuration outside its limits, a measurement the sensor flags invalid, a
//! non-finite or physically impossible ego speed, one older than `stale_periods`
//! periods, no plausible track yet, a track beyond its covered age (the certified fallback,
//! above), or a clock that jumps (backwards, or forwards by more than
//! [`MAX_STEP_GAP_PERIODS`] periods): each is a [`Fault`], reported in the command and logged,
//! and the command is the minimum-risk manoeuvre: a controlled deceleration of
//! `mrm_deceleration` (default 2 m/s^2, at most 4), softened to `mrm_gentle_deceleration` when
//! the follower is known, close and closing, so as not to provoke a rear-end collision. Where
//! the table is loaded and the leader track and the ego's speed are good (the fault is
//! elsewhere: the follower track, the clock), the front half still applies to that
//! deceleration exactly as to the nominal law: the speed cap and the look-ahead, so the
//! manoeuvre brakes harder, up to beta, when the leader needs it (after a clock jump the
//! forgotten history makes the look-ahead assume the band's top). A clock
//! jump is never latched: the new time is adopted, the command history forgotten, and the
//! manoeuvre ends after [`CLOCK_RECOVERY_PERIODS`] good periods. A board that restarted after
//! a fault of its own (watchdog, HardFault, panic) latches the manoeuvre until power-on
//! ([`Controller::latch_minimum_risk`], [`Fault::RestartedAfterFault`]). Every command, in
//! every mode, is clamped into the envelope, and (with a table) into the band, but for the
//! emergency authority's (above).
//!
//! # What `solver verify` proves of the rear table
//! `cargo run -p solver --release -- verify firmware/tables/default.bin` proves, by interval
//! bounds over every cell of the table and every admissible input (not by sampling), that every
//! state with `W > error_bound + rear_margin` (the firmware's rear test, `rear_margin` 0) is
//! safe from the follower for ever while the ego's acceleration stays in the band: for each
//! such state one of the periods 20, 100, 200 or 300 ms (chosen by the state) takes it, whatever
//! the ego does in the band and whatever time gap the IDM follower holds, to a state that passes
//! the test again, with the gap above zero in between; at standstill, below the gap where the
//! IDM brakes at its clip (0.756 m), a closed-form lemma keeps the gap above zero instead,
//! without the promise of a certified state at the next period ([`REAR_SAMPLE_TOLERANCE`] says
//! what holds there). The deployed table's figures are in docs/certificate.md (`solver::verify`
//! has the method and why the deployment table is solved with the follower pushed 0.2 m/s^2
//! beyond its model). The actuator's
//! dead time and lag do not enter: whatever they do, the realised acceleration stays in the
//! band when every command is in it. Between those periods the value may dip below the level:
//! by at most [`REAR_SAMPLE_TOLERANCE`] (10 cm) at every 20 ms sample, which verify proves from
//! its version 2 on. What it
//! does not claim: anything about `f32` rounding beyond `solver::verify::TOLERANCE`.
//!
//! # The tolerances, per part
//! Each part of a certified state's certificate is claimed to stay above its own stated
//! tolerance at every control period: the front half above `-CERTIFICATE_TOLERANCE` (1 cm,
//! `f32` rounding of the closed form), the rear half above `-REAR_SAMPLE_TOLERANCE` (10 cm,
//! proven by verify; above zero at its proof periods, except in the standstill lemma's region,
//! where the gap stays above zero), the speed headroom above
//! `-SPEED_TOLERANCE` (1 mm/s, `f32` rounding near 35 m/s).
//!
//! # What is assumed
//! The humans keep to the table's model (the leader brakes at most `-leader.min` and keeps its
//! speed in `[0, max_speed]`, the follower drives by the IDM with its time gap in range and
//! keeps its speed there too), and no vehicle cuts in; the measurements are within their
//! declared error bounds ([`Config::sensors`]) and time-stamped on the controller's clock (a
//! track of any age is argued from its time; the ego's speed at most `stale_periods` old; each
//! channel may have its own age); the actuator is a
//! dead time and a first-order lag no slower than the configuration declares, tracks the
//! acceleration over ground (a grade is its business, not the certificate's), and brakes at
//! beta when told to (and, for the emergency answer, at the emergency level, built up no slower
//! than declared); its reported state ([`Inputs::ego_acceleration`]) bounds what it
//! delivers before the controller's commands are known, within `sensors.acceleration_error`;
//! the control step comes every period. Nothing is assumed of the ego's speed: the firmware keeps
//! it in the domain (above). The front value is exact, and its look-ahead over the delays is argued
//! above and checked by property tests; its `f32` evaluation is within about 1.4 mm (measured),
//! inside [`CERTIFICATE_TOLERANCE`].

mod authorities;
mod certificate;
mod command;
mod emergency;
mod faults;
mod history;
mod law;
mod tracks;

pub use crate::config::{
    Authorities, CertificateConfig, Config, Envelope, FallbackConfig, LawConfig, OverridePolicy,
    PlantConfig, CLOCK_RECOVERY_PERIODS, ISO_15622_LIMITS, MAX_ACTUATOR_LAG_US, MAX_DEAD_TIME_US,
    MAX_PERIOD_US, MAX_STALE_PERIODS, MAX_STEP_GAP_PERIODS, MIN_PERIOD_US, TIME_GAP_SETTINGS,
};
pub use crate::driver::{DriverError, DriverRequest, DriverState};
pub use certificate::{
    Certificate, Certifier, CERTIFICATE_TOLERANCE, REAR_SAMPLE_TOLERANCE, SPEED_TOLERANCE,
};
pub use command::{Command, Event, Mode};
pub use faults::Fault;
pub use table_format::authority::Braking;
pub use table_format::EmergencyDeclaration;

use heapless::Deque;
use table_format::Table;

use crate::fmt::{log_info, log_warn};
use crate::inputs::{Inputs, Measurement};
use crate::iso15622;
use crate::math;
use crate::sensing::TrackState;

use certificate::{LeaderMemo, Model, Ramp, RearMemo};
use emergency::{EmergencyMemo, LightsHold};

/// How long [`Mode::Override`] is still reported after the look-ahead's last trim of the law's
/// command, microseconds: the label does not chatter while the law rides the look-ahead's edge.
pub const OVERRIDE_HOLD_US: u64 = 500_000;

/// How far below the domain's top, less three times the ego speed's error, the law's set speed
/// is held, m/s: room for the speed's rise under the commands in force (the dead time and lag
/// of the law's small corrections, the speed's ramp down) and the law's overshoot.
///
/// Why three errors: the law holds the *measured* speed `m` at its set speed, so a measurement
/// biased low by the error `E` leaves the true speed at `set + E`; the speed headroom is taken
/// at the top of the next measurement's box, `m' + E`, and that measurement may be biased high,
/// `m' = v + E`. So the headroom sees `set + 3E` plus the rise, and the law's set speed is held
/// at `max_ego_speed - 3E - SET_SPEED_ROOM` (34.08 m/s with the datasheet errors, `E` 0.275
/// m/s at 35) so that cruising at the top never leans on the speed cap. The rise measured in
/// the suite's steady following at 30 m/s (closing at the law's top behind a 9.8 m/s^2
/// leader, the error switching corners) is about 0.07 m/s
/// (`the_speed_near_the_domains_top_is_no_emergency_with_two_authorities`).
const SET_SPEED_ROOM: f32 = 0.1;

/// How long the law remembers the gentlest braking the follower allowed, microseconds: its
/// gap is the certificate's for the gentlest of the last one to two seconds. The level is
/// found at the worst corner of the follower measurement's box, which moves with every
/// measurement, so the level moves with the noise (4.1-4.2 m/s^2 behind a follower 1 s back at
/// 30 m/s, about 1.3 m of certified gap per 0.05 m/s^2); a law that took the last level as it
/// came followed at the best draw's gap and met the override at the next worse one.
const LAW_BRAKING_MEMORY_US: u64 = 1_000_000;

/// How far ahead the law looks at a follower closing on the ego, s: the following law
/// accelerates only as far as its gap policy lets with the braking the follower would allow
/// this long on, were it and the ego to keep the speeds of the follower measurement's worst
/// corner ([`Controller::allowed_ahead`]). A prediction for comfort, not a bound, and only a
/// cap on acceleration: it never makes the law brake, so a follower closing because the ego
/// slows cannot feed it (a gap policy that braked for it fell into a limit cycle of about 20 s
/// behind an IDM follower). Behind a follower closing at 3 m/s the level it allows fell
/// 4.26 -> 3.77 m/s^2 in 0.3 s at 19 m/s (about 15 m of front value per m/s^2 there), faster
/// than the law's memory forgets, and a law accelerating towards the remembered level's gap
/// met the override's build-up (by ISO 15622's jerk an emergency). With lossless radars
/// (200 episodes per group) the emergency periods from comfort starts in ISO 15622's scope
/// fell 43 -> 24 against a leader braking at 6 m/s^2 and 43 -> 16 at 9.8 with this horizon;
/// 36 and 17 with 2 s; 24 and 16 with 6 s, where the steady following behind an IDM follower
/// at 25 m/s settled 1.46 m from its policy (0.74 m with 4 s).
const LAW_FOLLOWER_HORIZON_S: f32 = 4.0;
use history::{seconds, IssuedCommands, LEAST, REPORTS};
use law::{Law, LawInputs};
use tracks::EGO_HISTORY;

/// The ACC safety controller. It owns the table and a log of recent events; it never allocates
/// and never panics. A clone is an independent controller in the same state (host-side
/// searches look ahead with one).
#[derive(Clone)]
pub struct Controller<'t> {
    certifier: Result<Certifier<'t>, Fault>,
    config: Config,
    mode: Mode,
    /// The last command's takeover request.
    takeover: bool,
    /// The time of the last step (`None` before the first).
    last_now_us: Option<u64>,
    /// Periods of the minimum-risk manoeuvre left after a clock jump, and its fault.
    clock_recovery: (u32, Fault),
    margin_lost: bool,
    events: Deque<Event, 32>,
    issued: IssuedCommands,
    /// The actuator's reported accelerations plus their error, one a period (`+inf` where none
    /// was valid and fresh), kept as the commands are: before the controller's own commands
    /// bound the actuator, they do (`Controller::reported_since`).
    reported: IssuedCommands<REPORTS>,
    /// With two authorities, the issued commands negated, kept as `issued` is: the least
    /// command since a time, for the rear check's credit
    /// (`Controller::least_issued_since`).
    least_issued: IssuedCommands<LEAST>,
    /// The braking ramp under way (`None`: the last command passed the look-ahead): the
    /// commands follow it since its start, not only from now (module docs: the braking ramp).
    ramp: Option<Ramp>,
    /// The last command passed the look-ahead (its ramp, if one was under way, ends).
    passed: bool,
    /// With two authorities, the speed's ramp under way (`None`: the last command fitted the
    /// speed cap): the ramp the speed headroom is argued along, at the slowest authority's jerk,
    /// kept from its start while the commands stay under it (module docs: the ego's speed).
    speed_ramp: Option<Ramp>,
    /// The last command fitted the speed cap (the speed's ramp, if one was under way, ends).
    speed_fitted: bool,
    /// With two authorities, the braking in force: the one the last passed look-ahead named,
    /// or the standby certificate's before an engagement (`None`: not known).
    in_force: Option<Braking>,
    /// With two authorities, the hardest braking the follower allowed the last look-ahead.
    allowed: Option<Braking>,
    /// With two authorities, the gentlest braking the follower allowed in the window under way
    /// and in the one before it (each [`LAW_BRAKING_MEMORY_US`] long, the first starting at
    /// the time kept): the law's gap is the certificate's with the gentler of the two.
    law_braking: Option<(u64, Option<Braking>, Option<Braking>)>,
    /// With two authorities, the braking the follower would allow [`LAW_FOLLOWER_HORIZON_S`]
    /// after the last look-ahead ([`Controller::allowed_ahead`]): a cap on the law's
    /// acceleration ([`Controller::law_gaps`]).
    law_ahead: Option<Braking>,
    /// The last command issued (`None` before the first, and after a cancel or a clock jump:
    /// then what the actuator does is only known from its reported state).
    last_command: Option<f32>,
    /// This period's reported actuator state plus its error, where valid and fresh.
    reported_acceleration: Option<f32>,
    /// The driver's controls.
    driver: DriverState,
    /// The nominal law's memory.
    law: Law,
    /// When the look-ahead last trimmed the law's command (the override's label is held after
    /// it).
    overridden_at_us: Option<u64>,
    /// Every step since the last engagement, cut-in or jump to beta kept a certified front
    /// (measured, a command that passed the look-ahead, or the ramp after either): the true
    /// state is certified while the ramp is followed, whatever the measurement noise does to
    /// the error box's corner.
    front_chain: bool,
    /// The last plausible leader measurement, with the ego's speed interval at its time.
    leader: Option<LeaderMemo>,
    /// Since when (the ego measurement's time of the first of an unbroken run of steps) every
    /// step's speed headroom was zero or more: from then on the ego's true speed has stayed
    /// within the domain.
    speed_kept_from_us: Option<u64>,
    /// The last plausible follower measurement, with its rear value at its time.
    rear: Option<RearMemo>,
    /// The last braking below the band, while its effect may last (module docs:
    /// emergencies).
    emergency: Option<EmergencyMemo>,
    /// With two authorities and the lights off: when the braking the certificate last argued
    /// with brings them on for sure, while every command since is under its ramp.
    lights_expected_us: Option<u64>,
    /// From when the brake lights are on for sure, while every command since a run of braking
    /// commands began has kept it (`Controller::keeps_lights_run`: at or below the lights'
    /// command, or below the lights' deceleration's negative once the run is lit; `None`: no
    /// run).
    lights_on_us: Option<u64>,
    /// When the last lights' run ended (its first command above the lights' command), while
    /// no run is under way (`Controller::look_ahead` watches the proposals for
    /// [`RELEASE_WATCH_US`](authorities::RELEASE_WATCH_US) after it).
    lights_off_at_us: Option<u64>,
    /// The same by the run's commands alone (`Controller::lights_run_starting` at its start,
    /// or its hold's): without the earlier on-time a look-ahead argued with
    /// (`lights_expected_us`), which holds only while the commands stay under that
    /// argument's ramp (`None`: no run).
    lights_run_own_us: Option<u64>,
    /// The lights' run under way has had a command below the band: its end is a release the
    /// follower must allow (`Controller::release_allowed`).
    run_went_below_band: bool,
    /// The braking the lights' run's on-time was counted from, while it must hold (module
    /// docs: emergencies).
    lights_hold: Option<LightsHold>,
    /// With two authorities: the last look-ahead sent the command down the comfortable way to
    /// the lights' command (`Controller::look_ahead`), which a proposal leaves only with
    /// [`LIGHTS_WAY_RELEASE_S`](authorities::LIGHTS_WAY_RELEASE_S) to spare.
    lights_way_down: bool,
    /// The certificate of the state measured in the last standby period (reset whenever a
    /// step is engaged), or why an engagement would be refused: what an engagement is judged
    /// by.
    standby_certificate: Result<Certificate, DriverError>,
    /// The latest ego-speed measurements `(time, speed)`, oldest first: the one nearest a
    /// track's time gives the ego's speed there.
    ego_history: Deque<(u64, f32), EGO_HISTORY>,
}

impl<'t> Controller<'t> {
    /// A controller running `table_bytes`. A table that does not parse, or is not a split
    /// three-car table, leaves the controller in the minimum-risk manoeuvre for good, with the
    /// reason in every command.
    pub fn new(table_bytes: &'t [u8], config: Config) -> Self {
        let certifier = if config.is_valid() {
            Table::parse(table_bytes)
                .map_err(Fault::Table)
                .and_then(|t| Certifier::new(t, &config))
        } else {
            Err(Fault::InvalidConfig)
        };
        if let Err(fault) = &certifier {
            log_warn!("table refused: {}", fault);
        }
        let mut config = config;
        config.fallback.mrm_deceleration = math::clamp(config.fallback.mrm_deceleration, 0.5, 4.0);
        config.fallback.mrm_gentle_deceleration = math::clamp(
            config.fallback.mrm_gentle_deceleration,
            0.5,
            config.fallback.mrm_deceleration,
        );
        Controller {
            certifier,
            config,
            mode: Mode::MinimumRisk,
            takeover: true,
            last_now_us: None,
            clock_recovery: (0, Fault::ClockJumped),
            margin_lost: false,
            events: Deque::new(),
            issued: IssuedCommands::new(),
            reported: IssuedCommands::new(),
            least_issued: IssuedCommands::new(),
            ramp: None,
            passed: false,
            speed_ramp: None,
            speed_fitted: false,
            in_force: None,
            allowed: None,
            law_braking: None,
            law_ahead: None,
            last_command: None,
            reported_acceleration: None,
            driver: DriverState::new(&config),
            law: Law::new(),
            front_chain: false,
            overridden_at_us: None,
            leader: None,
            speed_kept_from_us: None,
            rear: None,
            emergency: None,
            lights_on_us: None,
            lights_off_at_us: None,
            lights_run_own_us: None,
            lights_expected_us: None,
            run_went_below_band: false,
            lights_hold: None,
            lights_way_down: false,
            standby_certificate: Err(DriverError::CertificateUnknown),
            ego_history: Deque::new(),
        }
    }

    /// Ends certified control for good: every later step is the minimum-risk manoeuvre, with
    /// `fault` as its reason. For a board that restarted after a fault of its own (watchdog,
    /// HardFault, panic): software that failed once in a drive is not trusted again in that
    /// drive, so a restart brings the car to a stop instead of resuming control. The
    /// manoeuvre is the usual one (softened for a close, closing follower); nothing but a new
    /// controller ends it.
    pub fn latch_minimum_risk(&mut self, fault: Fault) {
        log_warn!("minimum-risk manoeuvre latched: {}", fault);
        self.certifier = Err(fault);
    }

    /// The table, if it was accepted.
    pub fn table(&self) -> Option<&Table<'t>> {
        self.certifier.as_ref().ok().map(Certifier::table)
    }

    /// The configuration in force (decelerations clamped to their limits).
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The mode of the last command.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The last command's takeover request ([`Command::takeover`]; true before the first
    /// command).
    pub fn takeover_requested(&self) -> bool {
        self.takeover
    }

    /// The driver's state: engaged or not, the set speed, the time-gap setting, the latest
    /// request's refusal: what the driver's display shows ([`crate::DriverDisplay`]).
    pub fn driver(&self) -> DriverState {
        self.driver
    }

    /// With two authorities ([`Authorities::Two`]), the hardest braking the follower allowed
    /// the last look-ahead (`None` before one, where it allowed none, and in the comfort band):
    /// the law's steady gap is the certificate's with it.
    pub fn allowed_braking(&self) -> Option<Braking> {
        self.allowed.filter(|_| self.two_authorities())
    }

    /// With two authorities, the braking the follower would allow the law's horizon
    /// (`LAW_FOLLOWER_HORIZON_S`) after the last look-ahead, were it and the ego to keep the
    /// speeds of the follower measurement's worst corner (`None` as for
    /// [`Controller::allowed_braking`]): the law accelerates only as far as its gap policy with
    /// it lets.
    pub fn braking_ahead(&self) -> Option<Braking> {
        self.law_ahead.filter(|_| self.two_authorities())
    }

    /// The speed the nominal law holds where nothing ahead is closer than its gap policy,
    /// m/s: the driver's set speed, at most the domain's top less three of the ego speed's
    /// errors and `SET_SPEED_ROOM` (34.08 m/s with the datasheet errors). The driver's set speed
    /// without a table.
    pub fn law_set_speed(&self) -> f32 {
        match &self.certifier {
            Ok(certifier) => self.law_set_speed_in(&certifier.model),
            Err(_) => self.driver.set_speed,
        }
    }

    /// [`Controller::law_set_speed`] with the table's model: below the domain's top by three
    /// of the speed's errors and a margin, because the certificate cannot certify an ego
    /// measured at the top (its speed headroom).
    fn law_set_speed_in(&self, model: &Model) -> f32 {
        math::min(
            self.driver.set_speed,
            model.max_ego_speed
                - 3.0
                    * (self.config.sensors.ego_speed(model.max_ego_speed).1 - model.max_ego_speed)
                - SET_SPEED_ROOM,
        )
    }

    /// The desired gap of the nominal law at `speed` with the driver's time-gap setting, m:
    /// the gap policy (the driver's `standstill_gap + time_gap v`, at least the gap the
    /// certificate needs while closing at `gap_room_speed`, plus `gap_room`) with the braking
    /// the law argues with ([`Controller::law_certified_gap`]).
    pub fn desired_gap(&self, speed: f32) -> f32 {
        self.gap_policy(speed, self.law_certified_gap(speed))
    }

    /// The gap the certificate needs at `speed` while the ego closes on its leader at the law's
    /// `gap_room_speed` (m), which the nominal law's gap policy keeps
    /// ([`Controller::closing_gap_with`]): for the braking the follower allowed the last
    /// look-ahead, or where none is known the braking in force; in the comfort band the band's.
    /// `+inf` without a table.
    pub fn law_certified_gap(&self, speed: f32) -> f32 {
        let Ok(certifier) = &self.certifier else {
            return f32::INFINITY;
        };
        let model = certifier.model;
        self.room_gap_with(speed, model.leader_braking, self.law_braking(&model))
    }

    /// The braking the law's gap argues with: the gentlest the follower allowed over the last
    /// one to two seconds (`law_braking`), or where none is known the last look-ahead's, or
    /// the braking in force; in the comfort band the band's.
    fn law_braking(&self, model: &Model) -> Braking {
        let remembered = self
            .law_braking
            .and_then(|(_, window, before)| gentler(window, before));
        remembered
            .or(self.allowed)
            .unwrap_or(self.braking_in_force(model))
    }

    /// The law's two gaps at `speed` (m): the gap the certificate needs while the ego closes
    /// on its leader at the law's `gap_room_speed` with the law's braking
    /// ([`Controller::law_certified_gap`]), and the same for the gentler of it and the braking
    /// the follower would allow [`LAW_FOLLOWER_HORIZON_S`] on (`law_ahead`), up to which the
    /// following law accelerates; the first where the follower is not seen to close (and in
    /// the comfort band, where `law_ahead` is `None`). One front evaluation, two where the
    /// follower closes.
    // (Inlined: called as a function it cost the default configuration's worst step 24
    // instructions on QEMU.)
    #[inline(always)]
    fn law_gaps(&self, model: &Model, speed: f32) -> (f32, f32) {
        let braking = self.law_braking(model);
        let certified_gap = self.room_gap_with(speed, model.leader_braking, braking);
        let ahead_gap = match self.law_ahead {
            Some(ahead) if ahead.level < braking.level => math::max(
                self.room_gap_with(speed, model.leader_braking, ahead),
                certified_gap,
            ),
            _ => certified_gap,
        };
        (certified_gap, ahead_gap)
    }

    /// [`Controller::closing_gap_with`] at the law's `gap_room_speed`.
    fn room_gap_with(&self, speed: f32, leader_braking: f32, braking: Braking) -> f32 {
        self.closing_gap_with(
            speed,
            self.config.law.gap_room_speed,
            leader_braking,
            braking,
        )
    }

    /// The gap policy at `speed` with the driver's time-gap setting over the certificate's gap
    /// `certified_gap` (m; law's module docs).
    fn gap_policy(&self, speed: f32, certified_gap: f32) -> f32 {
        let time_gap = self.config.time_gap(self.driver.time_gap_setting);
        Law::desired_gap(&self.config, time_gap, certified_gap, speed)
    }

    /// Keeps the gentlest braking the follower allowed, in windows of
    /// [`LAW_BRAKING_MEMORY_US`] (`law_braking`).
    fn remember_law_braking(&mut self, now: u64) {
        let allowed = self.allowed.filter(|_| self.two_authorities());
        self.law_braking = Some(match self.law_braking {
            Some((start, window, before))
                if now >= start && now - start < LAW_BRAKING_MEMORY_US =>
            {
                (start, gentler(window, allowed), before)
            }
            Some((start, window, _)) if now >= start && now - start < 2 * LAW_BRAKING_MEMORY_US => {
                (now, allowed, window)
            }
            // Long ago, or a clock that went back: start again.
            _ => (now, allowed, None),
        });
    }

    /// The gap policy at `speed` with the driver's time-gap setting against a leader braking at
    /// most at `leader_braking`, for an ego that answers with `braking` (m):
    /// [`Controller::desired_gap`] for another model or authority. `+inf` without a table.
    pub fn desired_gap_over(&self, speed: f32, leader_braking: f32, braking: Braking) -> f32 {
        self.gap_policy(speed, self.room_gap_with(speed, leader_braking, braking))
    }

    /// A request from the driver's controls (also taken from [`Inputs::driver`] in the step).
    /// Nothing but the driver's state changes: the command history stays, so the certificate
    /// keeps knowing what the actuator was told. A cancel forgets it (the driver drives until
    /// the next engagement, which the actuator's reported state covers). An engagement from
    /// standby (SET or resume) is refused unless the state measured in the last standby period
    /// is certified ([`DriverError::NotCertified`], [`DriverError::CertificateUnknown`]) and,
    /// with two authorities, the follower leaves the first engaged commands a comfortable way
    /// to brake ([`DriverError::NeedsEmergencyBraking`]): the car stays in standby.
    /// The outcome, refused or taken, is the driver state's latest ([`DriverState::refused`],
    /// [`DriverState::refusals`]), for the display.
    pub fn request(&mut self, request: DriverRequest) -> Result<(), DriverError> {
        let outcome = self.take_request(request);
        self.driver.record(outcome)
    }

    /// [`Controller::request`] but for recording its outcome.
    fn take_request(&mut self, request: DriverRequest) -> Result<(), DriverError> {
        let ego_speed = self.ego_history.back().map(|e| e.1);
        let was_engaged = self.driver.engaged;
        // An engagement (not a SET or resume while engaged) needs a certified state: the one
        // measured in the last standby period.
        if !was_engaged && matches!(request, DriverRequest::Engage | DriverRequest::Resume) {
            match self.standby_certificate {
                Ok(c) if c.is_certified() => {}
                Ok(_) => return Err(DriverError::NotCertified),
                Err(e) => return Err(e),
            }
        }
        self.driver
            .apply(request, ego_speed, self.config.plant.envelope.max_speed)?;
        if was_engaged && !self.driver.engaged {
            self.forget_commands();
        }
        Ok(())
    }

    /// Forgets what the actuator was told: from here on it is what its reported state says.
    fn forget_commands(&mut self) {
        self.front_chain = false;
        // The lights' run ends with the commands it was argued from.
        self.lights_on_us = None;
        self.lights_off_at_us = None;
        self.lights_run_own_us = None;
        self.lights_expected_us = None;
        self.run_went_below_band = false;
        self.lights_hold = None;
        self.lights_way_down = false;
        self.issued.forget();
        self.least_issued.forget();
        self.ramp = None;
        self.speed_ramp = None;
        self.in_force = None;
        // The law's cap was the last look-ahead's: its commands are forgotten with it.
        self.law_ahead = None;
        self.last_command = None;
        self.law.reset();
    }

    /// The actuator's reported state plus its error, if valid (finite, within 20 m/s^2) and
    /// no older than the ego speed's stale limit.
    fn reported(&self, m: &Measurement<f32>, now: u64) -> Option<f32> {
        let limit = u64::from(self.config.period_us) * u64::from(self.config.stale_periods);
        let fresh = m.timestamp_us <= now && now - m.timestamp_us <= limit;
        (m.valid && fresh && math::is_finite(m.value) && math::abs(m.value) <= 20.0)
            .then_some(m.value + self.config.sensors.acceleration_error)
    }

    /// The rear value of the kept follower measurement as the certificate may use it now: the
    /// table's value holds while the ego brakes within the band, so not for a measurement the
    /// effect of a braking below it reaches ([`Fault::AfterEmergencyBraking`]).
    fn rear_value_now(&self, rear: &RearMemo) -> Result<f32, Fault> {
        let value = rear.value?;
        if self.emergency_reaches(rear.at_us) {
            return Err(Fault::AfterEmergencyBraking);
        }
        Ok(value)
    }

    /// Recent events (the last 32), oldest first.
    pub fn events(&self) -> impl Iterator<Item = &Event> {
        self.events.iter()
    }

    /// Appends to the event log, dropping the oldest entry when it is full. (`heapless::Deque`
    /// rather than `HistoryBuf`: its ring arithmetic has no bounds check the optimiser cannot
    /// remove, so the control step keeps no panic path; see the `no-panic` binary.)
    fn log(&mut self, event: Event) {
        if self.events.is_full() {
            self.events.pop_front();
        }
        let _ = self.events.push_back(event);
    }

    /// One control step. Never inlined: it is the unit the target's cost figures (stack,
    /// instructions per step) are measured on.
    #[inline(never)]
    pub fn step(&mut self, inputs: &Inputs) -> Command {
        let now = inputs.now_us;
        // The clock: a step earlier than the last, or more than MAX_STEP_GAP_PERIODS periods
        // after it, is a jump. The new time is adopted (so a jump never latches), the command
        // history is forgotten (its time stamps belong to the old time line), and the
        // minimum-risk manoeuvre lasts CLOCK_RECOVERY_PERIODS good periods more.
        let max_gap = MAX_STEP_GAP_PERIODS * u64::from(self.config.period_us);
        let jump = match self.last_now_us {
            Some(last) if now < last => Some(Fault::ClockWentBackwards),
            Some(last) if now - last > max_gap => Some(Fault::ClockJumped),
            _ => None,
        };
        self.last_now_us = Some(now);
        self.reported_acceleration = self.reported(&inputs.ego_acceleration, now);
        if jump.is_some() {
            // The reports' times belong to the old time line.
            self.reported = IssuedCommands::new();
        }
        let keep_from = self.keep_commands_from(now);
        self.reported.push(
            now,
            self.reported_acceleration.unwrap_or(f32::INFINITY),
            keep_from,
        );
        if let Some(request) = inputs.driver {
            if let Err(error) = self.request(request) {
                self.log(Event::DriverRequestRefused { at_us: now, error });
            }
        }
        let model = self.certifier.as_ref().ok().map(|c| c.model);
        let floor = model.map(|m| self.ramp_floor(now, &m));
        let speed_floor = model
            .filter(|_| self.two_authorities())
            .map(|m| self.speed_floor(now, &m));
        self.passed = false;
        self.speed_fitted = false;
        let command = if !self.driver.engaged {
            self.standby(inputs)
        } else if let Some(fault) = jump {
            self.forget_commands();
            // The kept measurements' times belong to the old time line.
            self.leader = None;
            self.speed_kept_from_us = None;
            self.rear = None;
            self.ego_history.clear();
            self.clock_recovery = (CLOCK_RECOVERY_PERIODS, fault);
            self.minimum_risk(inputs, fault)
        } else if self.clock_recovery.0 > 0 {
            self.clock_recovery.0 -= 1;
            self.minimum_risk(inputs, self.clock_recovery.1)
        } else {
            self.decide(inputs)
        };
        let mut command = Command {
            acceleration: self.config.plant.envelope.clamp(command.acceleration),
            ..command
        };
        // The lights' hold, in every engaged mode: the run's on-time was counted from it.
        if let (Some(m), Some(hold), true) =
            (model, self.lights_hold, command.mode != Mode::Standby)
        {
            if now < hold.until_us && command.acceleration > hold.command {
                command.acceleration = hold.command;
                self.remember_below_band(now, hold.command, &m);
                // Not the law's: an override, and below the band an emergency.
                if command.mode == Mode::Nominal {
                    command.mode = Mode::Override;
                }
                if hold.command < m.ego.min {
                    command.emergency = true;
                    command.takeover = true;
                }
            }
        }
        // Braking faster than ISO 15622's jerk limit allows: an emergency (module docs).
        // Against the last command, or at engagement against the actuator's reported state.
        // Not where the ego may be standing (its measured speed's error box reaches zero): a
        // harder hold moves a car at rest nothing, and one that may still creep (at most
        // twice the speed's error at rest: 0.2 m/s by default) only stops the sooner, its
        // acceleration rising to zero. A speed not measured is not a standstill.
        let reference = self.last_command.or(self
            .reported_acceleration
            .map(|a| a - self.config.sensors.acceleration_error));
        let speed = self.ego_history.back().map_or(f32::NAN, |e| e.1);
        let standing = math::is_finite(speed) && self.config.sensors.ego_speed(speed).0 <= 0.0;
        if let (Some(last), true) = (reference, command.mode != Mode::Standby && !standing) {
            let allowed = iso15622::jerk_limit(speed) * seconds(u64::from(self.config.period_us));
            if last - command.acceleration > allowed * (1.0 + 1e-3) + 1e-4 {
                command.emergency = true;
                command.takeover = true;
            }
        }
        if command.mode != self.mode {
            self.log(Event::ModeChanged {
                at_us: now,
                to: command.mode,
                fault: command.fault,
            });
            log_info!("mode {} (fault {})", command.mode, command.fault);
        }
        self.mode = command.mode;
        self.takeover = command.takeover;
        if command.mode == Mode::Standby {
            return command;
        }
        self.standby_certificate = Err(DriverError::CertificateUnknown);
        // Every command goes to the actuator: the look-ahead of later steps must know it.
        let keep_from = self.keep_commands_from(now);
        self.issued.push(now, command.acceleration, keep_from);
        if self.two_authorities() {
            // A period further back: its query reaches for the command in force at its horizon.
            let keep_least_from = keep_from.saturating_sub(u64::from(self.config.period_us));
            self.least_issued
                .push(now, -command.acceleration, keep_least_from);
        }
        // The ramp (module docs): a command at or below the ramp's floor follows a ramp. One under
        // way keeps its start and reference; a new one starts now through the command itself
        // (reference `c + j h`, the command being the ramp's first: below the committed ramp
        // from the last command, since `c` is below its floor), or at beta for a command at
        // beta. A command above the floor passed the look-ahead (or is not certified at all).
        let c = command.acceleration;
        // The brake lights' run (module docs: emergencies).
        let (on, hold, own) = match model {
            Some(m) if c <= self.lights_command() => self.lights_run(now, &m, c),
            // A lit run kept by a gentler command (`Controller::keeps_lights_run`): on from
            // its own on-time, whatever a look-ahead argued with along a ramp it has left.
            Some(_) if self.keeps_lights_run(now, c) => {
                (self.lights_run_own_us, None, self.lights_run_own_us)
            }
            _ => (None, None, None),
        };
        self.lights_run_own_us = own;
        self.lights_off_at_us = match (self.lights_on_us, on) {
            (Some(_), None) => Some(now),
            (_, Some(_)) => None,
            (None, None) => self.lights_off_at_us,
        };
        self.lights_on_us = on;
        self.lights_hold = hold;
        self.run_went_below_band = self.lights_on_us.is_some()
            && (self.run_went_below_band || model.is_some_and(|m| c < m.ego.min));
        // A command that passed the look-ahead ends the ramp: the next step's committed ramp
        // is the one the look-ahead argued with, from this command.
        let h = seconds(u64::from(self.config.period_us));
        self.ramp = match (model, floor) {
            (Some(m), Some(floor)) if c <= floor && !self.passed => {
                let Braking { level, jerk } = self.braking_in_force(&m);
                Some(self.ramp.unwrap_or(Ramp {
                    start_us: now,
                    from: if c <= -level || !math::is_finite(jerk) {
                        -level
                    } else {
                        c + jerk * h
                    },
                }))
            }
            _ => None,
        };
        // The speed's ramp (two authorities): a command that did not fit the speed cap is at or
        // below the speed's ramp, which goes on (one under way keeps its start and reference; a
        // new one starts now through the command, as the braking ramp does). A command that
        // fitted ends it: the next step's speed headroom is the one the cap argued with.
        self.speed_ramp = match (model, speed_floor) {
            (Some(m), Some(speed_floor))
                if self.two_authorities() && c <= speed_floor && !self.speed_fitted =>
            {
                let jerk = self.speed_jerk(&m);
                Some(self.speed_ramp.unwrap_or(Ramp {
                    start_us: now,
                    from: c + jerk * h,
                }))
            }
            _ => None,
        };
        self.last_command = Some(c);
        let config = self.config;
        self.law
            .settle(&config, c, seconds(u64::from(config.period_us)));
        command
    }

    /// Disengaged: no command for the actuator to follow; the tracks and the ego's speed are
    /// still observed, so that an engagement starts from known measurements.
    ///
    /// The certificate of the measured state is evaluated as an engaged step would (the front
    /// at the error box's worst corner, with the committed ramp from what the actuator may be
    /// doing; the rear over the box): an engagement is judged by it, and the command's margin
    /// carries it, so that the driver sees when the car can be engaged.
    fn standby(&mut self, inputs: &Inputs) -> Command {
        let now = inputs.now_us;
        self.standby_certificate = Err(DriverError::CertificateUnknown);
        self.speed_ramp = None;
        let mut command = Command::bare(0.0, Mode::Standby, None);
        let (Ok(model), Ok(v)) = (
            self.certifier.as_ref().map(|c| c.model),
            self.check_ego_speed(&inputs.ego_speed, now),
        ) else {
            return command;
        };
        let t_e = inputs.ego_speed.timestamp_us;
        self.remember_ego_speed(t_e, v);
        command.leader = self.observe_leader(&inputs.leader, now, &model);
        command.follower = self.observe_follower(&inputs.follower, now, &model);
        let usable = |s: TrackState| !matches!(s, TrackState::Lost | TrackState::Missing);
        let (Some(leader), Some(rear), true) = (
            self.leader,
            self.rear,
            usable(command.leader) && usable(command.follower),
        ) else {
            return command;
        };
        let pending = self.pending(leader.at_us.min(t_e), &model);
        // With two authorities, the braking an engagement starts with: the look-ahead's from what
        // the actuator is doing (the hardest the follower allows), its lights argued from the
        // period after this one, where the first engaged step's ramp starts.
        if self.two_authorities() {
            let doing = self.last_command_or_unknown(&model);
            self.in_force = self.look_ahead_braking(&model, now, doing);
            let pending_now = self.pending(now, &model);
            self.lights_expected_us = self
                .in_force
                .and_then(|b| self.ramp_lights_on(now, pending_now, doing, b.jerk, b.level));
        }
        let braking = self.braking_in_force(&model);
        let front = self.measured_front(&model, &leader, v, t_e, now, pending, braking);
        let certificate = if self.two_authorities() {
            match (self.in_force, self.lights_expected_us) {
                (Some(b), Some(on)) => Ok(Certificate {
                    front: front.value - self.config.certificate.front_margin,
                    rear: self.rear_slack_at(&model, b, on, now),
                    speed: front.headroom,
                }),
                _ => Err(DriverError::NotCertified),
            }
        } else {
            match (&self.certifier, self.rear_value_now(&rear)) {
                (Ok(c), Ok(w)) => Ok(c.certificate_of(front.value, w, front.headroom)),
                _ => Err(DriverError::NotCertified),
            }
        };
        command.margin = certificate.ok().map(|c| c.margin());
        // With two authorities a certified state is engaged only where the follower leaves
        // the first engaged steps a comfortable way: they would otherwise jump, an emergency
        // the driver did not ask for.
        let front_certified = |b: Braking| {
            b.level >= braking.level
                || self.front_certifies(&model, &leader, v, t_e, now, pending, b)
        };
        let refused = self.two_authorities()
            && certificate.is_ok_and(|c| c.is_certified())
            && !self.engages_comfortably(&model, now, v, front_certified);
        self.standby_certificate = if refused {
            Err(DriverError::NeedsEmergencyBraking)
        } else {
            certificate
        };
        // The speed's ramp an engagement starts on: the one this certificate argued along (from
        // what the actuator may be doing now), not one restarted from a later report.
        if self.two_authorities() {
            self.speed_ramp = Some(self.committed_speed_ramp(now, &model).0);
        }
        command
    }

    /// The minimum-risk deceleration, reached from the last command at ISO 15622's jerk limit
    /// (a controlled deceleration, not a jab).
    fn comfortable(&self, deceleration: f32, inputs: &Inputs) -> f32 {
        let Some(last) = self.last_command else {
            return -deceleration;
        };
        let v = inputs.ego_speed.value;
        let step = iso15622::jerk_limit(v) * seconds(u64::from(self.config.period_us));
        math::max(-deceleration, last - step)
    }

    fn minimum_risk(&mut self, inputs: &Inputs, fault: Fault) -> Command {
        let deceleration = self.mrm_deceleration(inputs);
        let mut command = Command::bare(
            self.comfortable(deceleration, inputs),
            Mode::MinimumRisk,
            Some(fault),
        );
        command.takeover = true;
        let Ok(Certifier { model, .. }) = &self.certifier else {
            return command;
        };
        let model = *model;
        let planned = math::clamp(command.acceleration, model.ego.min, model.ego.max);
        command.acceleration = planned;
        // The front half still applies where its inputs are good (module docs): the manoeuvre
        // brakes harder when the leader needs it, never more than beta.
        let now = inputs.now_us;
        if let (Some(leader), Ok(ego_speed)) =
            (self.leader, self.check_ego_speed(&inputs.ego_speed, now))
        {
            let t_e = inputs.ego_speed.timestamp_us;
            let pending = self.pending(leader.at_us.min(t_e), &model);
            let front_certified =
                |b: Braking| self.front_certifies(&model, &leader, ego_speed, t_e, now, pending, b);
            let look = self.look_ahead(&model, now, planned, ego_speed, &front_certified);
            if self.two_authorities() && self.in_force.is_none() {
                self.in_force = look.map(|l| l.braking);
            }
            let front =
                self.enforce_front(&model, &leader, ego_speed, t_e, now, pending, planned, look);
            self.note_decision(&model, now, front.passed, front.named, look);
            self.speed_fitted = front.speed_fits;
            command.acceleration = front.command;
            command.leader = self.track_state(leader.at_us, now);
        }
        command
    }

    /// The minimum-risk deceleration: `mrm_deceleration`, softened to
    /// `mrm_gentle_deceleration` when the follower is known, close and closing (by this
    /// period's plausible track, or the last one kept).
    fn mrm_deceleration(&self, inputs: &Inputs) -> f32 {
        let c = &self.config;
        let follower = if self.is_plausible(&inputs.follower, inputs.now_us) {
            Some(inputs.follower.value)
        } else {
            self.rear.map(|r| r.track)
        };
        let close_and_closing = follower.is_some_and(|t| {
            math::is_finite(t.gap) && t.gap < c.fallback.follower_close_gap && t.rel_speed < 0.0
        });
        if close_and_closing {
            c.fallback.mrm_gentle_deceleration
        } else {
            c.fallback.mrm_deceleration
        }
    }

    fn decide(&mut self, inputs: &Inputs) -> Command {
        let model = match &self.certifier {
            Ok(c) => c.model,
            Err(f) => return self.minimum_risk(inputs, *f),
        };
        let now = inputs.now_us;
        let ego = inputs.ego_speed;
        let ego_speed = match self.check_ego_speed(&ego, now) {
            Ok(v) => v,
            Err(f) => return self.minimum_risk(inputs, f),
        };
        let t_e = ego.timestamp_us;
        self.remember_ego_speed(t_e, ego_speed);
        let leader_state = self.observe_leader(&inputs.leader, now, &model);
        let follower_state = self.observe_follower(&inputs.follower, now, &model);
        let with_tracks = |mut c: Command| {
            c.leader = leader_state;
            c.follower = follower_state;
            c
        };
        let Some(leader) = self.leader else {
            return with_tracks(self.minimum_risk(inputs, Fault::LeaderInvalid));
        };
        if leader_state == TrackState::New {
            self.law.forget_leader();
            self.front_chain = false;
        }
        let Some(rear) = self.rear else {
            return with_tracks(self.minimum_risk(inputs, Fault::FollowerInvalid));
        };
        // Beyond the covered age: the certified fallback (module docs), the minimum-risk
        // deceleration under the front half of the last good leader measurement.
        let lost = match (leader_state, follower_state) {
            (TrackState::Lost, _) => Some(Fault::LeaderStale),
            (_, TrackState::Lost) => Some(Fault::FollowerStale),
            _ => None,
        };
        // An engagement without a standby period before it (or after a clock jump) starts with
        // the braking a look-ahead from what the actuator may be doing argues with: its
        // certificate is judged by it.
        if self.two_authorities() && self.in_force.is_none() {
            let doing = self.last_command_or_unknown(&model);
            self.in_force = self.look_ahead_braking(&model, now, doing);
        }
        let proposal = match lost {
            Some(_) => math::clamp(
                self.comfortable(self.mrm_deceleration(inputs), inputs),
                model.ego.min,
                model.ego.max,
            ),
            None => {
                // (The config is read in place, not copied: a copy cost the default
                // configuration's step about 160 instructions of `memcpy` on the Cortex-M4F.)
                // Only a vehicle ahead needs the gap policy.
                let (certified_gap, ahead_gap) = if math::is_finite(leader.track.gap) {
                    self.law_gaps(&model, ego_speed)
                } else {
                    (f32::INFINITY, f32::INFINITY)
                };
                let x = LawInputs {
                    leader: Some((leader.at_us, leader.track)),
                    ego_speed,
                    now_us: now,
                    period: seconds(u64::from(self.config.period_us)),
                    set_speed: self.law_set_speed_in(&model),
                    time_gap: self.config.time_gap(self.driver.time_gap_setting),
                    certified_gap,
                    ahead_gap,
                    last_command: self.last_command_or_unknown(&model),
                    resume: self.driver.resume_requested,
                    speed_error: self.config.sensors.ego_speed(ego_speed).1 - ego_speed,
                    stop_deceleration: self.stop_deceleration(),
                };
                let a = self.law.propose(&self.config, &x);
                if !self.law.is_holding() {
                    self.driver.resume_requested = false;
                }
                math::clamp(a, model.ego.min, model.ego.max)
            }
        };
        let pending = self.pending(leader.at_us.min(t_e), &model);
        // The look-ahead's braking (with two authorities, the level the follower allows every
        // command up to the proposal).
        let front_certified =
            |b: Braking| self.front_certifies(&model, &leader, ego_speed, t_e, now, pending, b);
        let look = self.look_ahead(&model, now, proposal, ego_speed, &front_certified);
        self.lights_way_down = look.is_some_and(|l| l.way_down);
        self.allowed = look.map(|l| l.braking);
        self.law_ahead = look.and_then(|l| self.allowed_ahead(&model, &l, LAW_FOLLOWER_HORIZON_S));
        self.remember_law_braking(now);
        let mut front = self.enforce_front(
            &model, &leader, ego_speed, t_e, now, pending, proposal, look,
        );
        self.note_decision(&model, now, front.passed, front.named, look);
        // Every later change of the command lowers it: it fits the speed cap where this one
        // did (the peak is non-decreasing in the command).
        self.speed_fitted = front.speed_fits;
        // The emergency answer: as hard as the leader's worst case needs, gentler than the
        // band's floor where that suffices, harder under the emergency authority where it does
        // not (module docs: emergencies).
        let answer = match front.jumped {
            true => {
                let floor = self.ramp_floor(now, &model);
                let level = self.emergency_answer(&model, &leader, now, pending, floor);
                front.command = -level;
                Some(level)
            }
            false => None,
        };
        let below_band = answer.filter(|level| -*level < model.ego.min);
        // The end of a run that braked below the band, or the lights off while such a braking
        // may still act: the follower must allow it, or the lights go on (module docs:
        // emergencies).
        if below_band.is_none()
            && !self.two_authorities()
            && (self.run_went_below_band || self.emergency_reaches(now))
            && self.ends_lights_run(now, front.command)
            && !self.release_allowed(&model, now, front.command, 0, None)
        {
            // Down the braking ramp the last check passed with, to the gentlest braking that
            // keeps the run.
            let keeping = self.gentlest_keeping_run(now);
            let jerk = self.config.certificate.brake_jerk;
            let down = if math::is_finite(jerk) {
                self.last_command_or_unknown(&model)
                    - jerk * seconds(u64::from(self.config.period_us))
            } else {
                keeping
            };
            front.command = math::min(front.command, math::max(keeping, down));
        }
        // Every command below the band (the emergency answer's, or with two authorities the
        // ramp of the braking in force) is remembered while its effect may last.
        self.remember_below_band(now, front.command, &model);
        self.front_chain = (front.value > self.config.certificate.front_margin
            && front.headroom >= 0.0)
            || front.passed
            || (self.front_chain && !front.jumped);
        self.speed_kept_from_us = if front.headroom >= 0.0 {
            self.speed_kept_from_us.or(Some(t_e))
        } else {
            None
        };
        // The override's label is held for OVERRIDE_HOLD_US after its last trim, so that a law
        // riding the look-ahead's edge (the command continuous) does not flip the mode every
        // period.
        if front.overridden {
            self.overridden_at_us = Some(now);
        }
        let held = self
            .overridden_at_us
            .is_some_and(|at| now.saturating_sub(at) < OVERRIDE_HOLD_US);
        let mode = match (lost, front.overridden || held) {
            (Some(_), _) => Mode::MinimumRisk,
            (None, true) => Mode::Override,
            (None, false) => Mode::Nominal,
        };
        let front_certified = front.value > self.config.certificate.front_margin;
        let mut command = with_tracks(Command::bare(front.command, mode, lost));
        command.takeover = lost.is_some() || !front_certified;
        // The emergency answer (in the band, or under the emergency authority), every
        // period it is given.
        if front.jumped {
            command.emergency = true;
            command.takeover = true;
        }
        // With two authorities the rear half is the braking in force's, in closed form.
        if self.two_authorities() {
            let certificate = Certificate {
                front: front.value - self.config.certificate.front_margin,
                rear: self.rear_slack(&model, now, self.braking_in_force(&model)),
                speed: front.headroom,
            };
            command.margin = Some(self.note_margin(now, certificate.margin()));
            return command;
        }
        // Outside the rear table's domain the front override (and the speed cap) still act:
        // only the rear half is unknown (module docs).
        let rear = match self.rear_value_now(&rear) {
            Ok(w) => w,
            Err(fault) => {
                if lost.is_none() {
                    command.mode = Mode::Uncertified;
                    command.fault = Some(fault);
                }
                command.takeover = true;
                return command;
            }
        };
        let margin = match &self.certifier {
            Ok(c) => c.certificate_of(front.value, rear, front.headroom).margin(),
            Err(_) => f32::NAN,
        };
        command.margin = Some(self.note_margin(now, margin));
        command
    }

    /// Diagnostics: the state itself is no longer certified (logged once per excursion).
    fn note_margin(&mut self, now: u64, margin: f32) -> f32 {
        let outside = margin.is_nan() || margin <= 0.0;
        if outside && !self.margin_lost {
            self.log(Event::MarginLost { at_us: now, margin });
        }
        self.margin_lost = outside;
        margin
    }
}

/// The gentler of two brakings (the lower level), either where one is unknown.
fn gentler(a: Option<Braking>, b: Option<Braking>) -> Option<Braking> {
    match (a, b) {
        (Some(a), Some(b)) => Some(if b.level < a.level { b } else { a }),
        (a, b) => a.or(b),
    }
}
