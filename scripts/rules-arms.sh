# The learning-rules protocol's arms (docs/notebook/2026-12-02-learning-rules-protocol.md),
# sourced by scripts/rules-screen.sh (stage 1) and scripts/rules-confirm.sh (stage 2): one
# definition of each arm's settings.
#
# arm_options ARM    sets the array OPTS to the arm's `--set` options (after `--preset main`)
# arm_control ARM    prints the backprop arm with the same optimiser and loss settings
FA=(--set learning_rule=feedback-alignment)
SGD=(--set cortex.train.optimizer=sgd --set cortex.train.learning_rate=0.03
     --set cortex.train.clip_global_norm=1)
EPS=(--set cortex.train.adam_eps=1)
GUARD=(--set cortex.loss.outside_field_weight=1)

arm_options() {
    case "$1" in
        B0) OPTS=() ;;
        F0) OPTS=("${FA[@]}") ;;
        F1) OPTS=("${FA[@]}" "${EPS[@]}") ;;
        B1) OPTS=("${EPS[@]}") ;;
        F2) OPTS=("${FA[@]}" "${SGD[@]}") ;;
        B2) OPTS=("${SGD[@]}") ;;
        F3) OPTS=("${FA[@]}" "${GUARD[@]}") ;;
        B3) OPTS=("${GUARD[@]}") ;;
        K1) OPTS=(--set learning_rule=kolen-pollack --set rule.learning_rate=1e-4) ;;
        D1) OPTS=(--set learning_rule=direct-feedback-alignment "${EPS[@]}") ;;
        G0) OPTS=(--set learning_rule=forward-forward) ;;
        G1) OPTS=(--set learning_rule=forward-forward --set rule.objective=prediction) ;;
        *) echo "unknown arm $1" >&2; return 2 ;;
    esac
}

arm_control() {
    case "$1" in
        F1 | D1) echo B1 ;;
        F2) echo B2 ;;
        F3) echo B3 ;;
        B*) echo "$1" ;;
        *) echo B0 ;;
    esac
}
