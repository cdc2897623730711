//! Identifiability of a standard compensation box versus one without its yaw maneuvers, and of
//! the perm V / induced VV−TT pair the patent separates with large wing-ups.

use tolles_core::flight::plan::BoxPlan;
use tolles_core::flight::sim::Scenario;
use tolles_core::maneuvers::identifiability::{
    analyse_mapped, candidate_blocks, patent_map, planned_blocks, suggest, Block, Identifiability,
};
use tolles_core::model::design::Design;
use tolles_core::model::interpret::AircraftField;
use tolles_core::signal::filter::magnav_bandpass;

fn design() -> Design {
    Design::new("permanent,i5,e8".parse().unwrap())
}

fn blocks(plan: &BoxPlan) -> Vec<Block> {
    let filter = magnav_bandpass(0.1, 0.9, 4, 10.0).unwrap();
    let scenario = Scenario::new(AircraftField::default(), 1);
    planned_blocks(&plan.build(), &scenario, &design(), filter.as_ref()).unwrap()
}

fn evaluate(blocks: &[Block]) -> Identifiability {
    let (names, map) = patent_map(&design(), 10.0);
    analyse_mapped(blocks, &names, &map, 0.01)
}

fn term<'a>(
    report: &'a Identifiability,
    name: &str,
) -> &'a tolles_core::maneuvers::identifiability::TermInformation {
    report.terms.iter().find(|t| t.name == name).unwrap()
}

#[test]
fn yaws_on_east_and_west_carry_the_eddy_terms_of_the_forward_field() {
    let full = evaluate(&blocks(&BoxPlan::default()));
    let no_yaw = evaluate(&blocks(&BoxPlan {
        yaw_deg: 0.0,
        ..BoxPlan::default()
    }));
    for name in ["lt", "lv"] {
        let (with, without) = (term(&full, name), term(&no_yaw, name));
        // In the full box the east/west yaws carry part of this term's information: without
        // either, its variance grows by more than 5 %, more than without any other yaw…
        let inflation = |label: &str| with.carried_by.iter().find(|(l, _)| l == label).unwrap().1;
        for label in ["yaw on 090°", "yaw on 270°"] {
            assert!(
                inflation(label) > 1.05,
                "{name}: {label} ×{}",
                inflation(label)
            );
            assert!(inflation(label) > inflation("yaw on 000°"), "{name}");
        }
        // …without them the box has no yaw blocks and the term is less well known.
        assert!(without
            .carried_by
            .iter()
            .all(|(l, _)| !l.starts_with("yaw")));
        assert!(without.std_error > 1.05 * with.std_error, "{name}");
    }
    // Terms the yaws do not see are unchanged.
    let ratio = term(&no_yaw, "vv-tt").std_error / term(&full, "vv-tt").std_error;
    assert!((ratio - 1.0).abs() < 0.01, "{ratio}");
}

#[test]
fn perm_v_and_induced_vv_tt_are_collinear_on_a_box_and_wing_ups_fix_it() {
    let flown = blocks(&BoxPlan::default());
    let report = evaluate(&flown);
    let v = term(&report, "V");
    assert!(v.collinear, "V VIF {}", v.vif);
    assert!(
        v.partners
            .iter()
            .any(|(p, r)| p == "VV-TT" && r.abs() > 0.9),
        "{:?}",
        v.partners
    );
    let filter = magnav_bandpass(0.1, 0.9, 4, 10.0).unwrap();
    let scenario = Scenario::new(AircraftField::default(), 1);
    let candidates = candidate_blocks(&scenario, &design(), filter.as_ref()).unwrap();
    let (names, map) = patent_map(&design(), 10.0);
    let j = names.iter().position(|n| n == "V").unwrap();
    let ranked = suggest(&flown, &candidates, &map, j);
    assert!(ranked[0].0.contains("wing-up"), "{:?}", &ranked[..3]);
    assert!(ranked[0].1 < 0.7, "{:?}", ranked[0]);
}
