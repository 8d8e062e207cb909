//! The generated fleet type answers every per-model query as the model it names does, and a
//! single model stands in for a fleet of one (index ignored).

use omcbsa_core::model::{Fleet7, Frame, FrankaPanda, KinovaGen3, Model, Models};
use omcbsa_core::rng::Rng;

fn same<A: Model<7>>(id: u8) {
    assert_eq!(Fleet7::name(id), A::NAME);
    assert_eq!(Fleet7::link_names(id), A::LINK_NAMES);
    assert_eq!(Fleet7::joint_names(id), &A::JOINT_NAMES);
    assert_eq!(Fleet7::lower(id), &A::LOWER);
    assert_eq!(Fleet7::upper(id), &A::UPPER);
    assert_eq!(Fleet7::velocity(id), &A::VELOCITY);
    assert_eq!(Fleet7::acceleration(id), &A::ACCELERATION);
    assert_eq!(Fleet7::capsules(id), A::CAPSULES);
    assert_eq!(Fleet7::self_pairs(id), A::SELF_PAIRS);
    assert_eq!(Fleet7::reach(id), &A::REACH);
    assert_eq!(Fleet7::capsule_reach(id), A::CAPSULE_REACH);
    assert_eq!(Fleet7::tool_self_capsules(id), A::TOOL_SELF_CAPSULES);
    assert_eq!(Fleet7::tool_reach(id), &A::TOOL_REACH);
    let mut rng = Rng::new(u64::from(id) + 7);
    for _ in 0..20 {
        let q = rng.configuration(&A::LOWER, &A::UPPER);
        assert_eq!(Fleet7::fk(id, &q), A::fk(&q));
        assert_eq!(Fleet7::jacobian(id, &q), A::jacobian(&q));
        let (mut a, mut b) = ([Frame::IDENTITY; 16], [Frame::IDENTITY; 16]);
        let n = A::LINK_NAMES.len();
        assert_eq!(
            Fleet7::link_frames(id, &q, &mut a[..n]),
            A::link_frames(&q, &mut b[..n])
        );
        assert_eq!(a, b);
    }
}

#[test]
fn the_fleet_dispatches_each_index_to_its_model() {
    assert_eq!(Fleet7::COUNT, 2);
    same::<KinovaGen3>(0);
    same::<FrankaPanda>(1);
    assert_eq!(Fleet7::find("franka_panda"), Some(1));
    assert_eq!(Fleet7::find("kinova_gen3"), Some(0));
    assert_eq!(
        Fleet7::find("synthetic_chain"),
        None,
        "another DoF, another fleet"
    );
    // Out of range reads as the last model (the loader never gives one).
    assert_eq!(Fleet7::name(9), FrankaPanda::NAME);
}

#[test]
fn one_model_is_a_fleet_of_one() {
    assert_eq!(<KinovaGen3 as Models<7>>::COUNT, 1);
    assert_eq!(<KinovaGen3 as Models<7>>::name(3), "kinova_gen3");
    assert_eq!(KinovaGen3::find("kinova_gen3"), Some(0));
    assert_eq!(KinovaGen3::find("franka_panda"), None);
}
