//! Fibonacci: a response whose slots are the shape of the ROS 2 action
//! `test_msgs/action/Fibonacci`, so it can be served as that action
//! (`[[ros2.serve]]`, docs/ros2.md). `start(goal)` works the sequence out
//! to `order` terms, one every `step_ms` (default 100 ms), emitting the
//! sequence so far as its signal `feedback` after each, and returns the
//! whole sequence; an interrupt ends it between terms.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:fibonacci;

    /// The action's messages, as `radar ros2 show
    /// test_msgs/action/Fibonacci --wit` prints them.
    interface messages {
        /// test_msgs/action/Fibonacci_Goal
        record goal {
            order: s32,
        }
        /// test_msgs/action/Fibonacci_Result (and _Feedback)
        record sequence {
            sequence: list<s32>,
        }
    }

    interface signals {
        use messages.{sequence};
        /// The sequence so far.
        feedback: func(so-far: sequence);
    }

    interface slots {
        use radar:reactive/types@0.1.0.{interruption};
        use messages.{goal, sequence};
        /// Works the sequence out to `order` terms.
        start: func(goal: goal) -> result<sequence, interruption>;
    }

    world fibonacci {
        include radar:reactive/response@0.1.0;
        import signals;
        export slots;
    }
"#
);

use exports::radar_examples::fibonacci::slots::Guest;
use radar_examples::fibonacci::messages::{Goal, Sequence};
use radar_examples::fibonacci::signals;

struct Fibonacci;

impl Guest for Fibonacci {
    fn start(goal: Goal) -> Result<Sequence, Interrupted> {
        let step = Duration::from_millis(config_or("step_ms", 100u64));
        let mut sequence: Vec<i32> = vec![0, 1];
        for _ in 1..goal.order {
            sleep(step)?;
            let next = sequence[sequence.len() - 1].saturating_add(sequence[sequence.len() - 2]);
            sequence.push(next);
            signals::feedback(&Sequence {
                sequence: sequence.clone(),
            });
        }
        Ok(Sequence { sequence })
    }
}

export!(Fibonacci);
