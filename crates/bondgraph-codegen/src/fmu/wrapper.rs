//! The FMI 3.0 functions in C over the C backend's generator: an instance holds the
//! generator, its settings, the inputs and the last outputs; `fmi3DoStep` pushes one sample.

use std::fmt::Write as _;

use bondgraph_core::Compiled;

use super::variables::{sizable, Causality, Role, Type, Variable};
use crate::c::string;

/// The FMI types, written from the standard.
const TYPES: &str = include_str!("fmi3_types.h");
/// The functions this FMU refuses.
const UNSUPPORTED: &str = include_str!("unsupported.c");

/// The wrapper's source for the model whose C code has the prefix `id`.
pub(super) fn emit(c: &Compiled, id: &str, vars: &[Variable], token: &str) -> String {
    let program = c.program();
    let (r, raw) = (program.residuals.len(), program.raw.len());
    let names_len: usize = c.components.values().map(|k| k.name.len() + 1).sum();
    let places: Vec<String> = sizable(c).iter().map(|(k, _)| k.to_string()).collect();
    let mut s =
        format!(
        "/* The FMI 3.0 co-simulation interface of the residual generator of `{name}`, written by
   bgc. Each fmi3DoStep(t, h) takes the inputs set for t as the record's sample at t. */
#include \"{id}.h\"

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

{TYPES}
/* The token the model description gives: an FMU instantiated for another is refused. */
#define TOKEN {token}

typedef enum {{ INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED }} Mode;

/* One instance: the generator, its settings, the inputs and the last outputs. */
typedef struct {{
    {id}_generator generator;
    {id}_params params;
    {id}_output out;
    double raw[{raw_dim}];
    double levels[{r_dim}];
    double step, time;
    int window, degree, integration, debounce;
    bool adaptive, ready, logging;
    char candidates[{cand}];
    {id}_size sizes[{sized_dim}];
    bgc_size size_out[{sized_dim}];
    double noise[{r_dim}];
    int size_memory;
    bool size_on[{sized_dim}], sizing;
    Mode mode;
    char *name;
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
}} Instance;

/* The place among the model's parameters of each one whose size can be estimated. */
static const int places[{sized_dim}] = {{{places}}};
",
        name = crate::c::comment(&c.name),
        token = string(token),
        raw_dim = raw.max(1),
        r_dim = r.max(1),
        cand = names_len.max(1),
        sized_dim = places.len().max(1),
        places = if places.is_empty() { "0".to_string() } else { places.join(", ") },
    );
    s += &helpers(id, vars, r);
    s += &sizes(id, r, places.len());
    s += &lifecycle(id, r);
    for ty in [
        "Float32", "Float64", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64",
        "UInt64", "Boolean", "String",
    ] {
        s += &getter(ty, vars);
        s += &setter(ty, vars);
    }
    s += &do_step(id, r);
    s += "\n";
    s += UNSUPPORTED;
    s
}

/// The defaults, the logger and the refusals.
fn helpers(id: &str, vars: &[Variable], r: usize) -> String {
    let mut defaults = String::new();
    for v in vars {
        // The one string, the candidates, is an output: it has no start to set.
        let Some(start) = v.start.as_ref().filter(|_| v.ty != Type::String) else {
            continue;
        };
        let _ = writeln!(defaults, "    {} = {start};", v.role.place());
    }
    format!(
        "
/* Says `message` through the importer's logger, if it gave one. */
static void say(const Instance *m, fmi3Status status, const char *message)
{{
    if (m != NULL && m->log != NULL)
        m->log(m->environment, status, \"logStatusError\", message);
}}

/* A call this FMU does not support. */
static fmi3Status refuse(fmi3Instance instance, const char *function)
{{
    char message[160];
    snprintf(message, sizeof message, \"%.60s is not supported by this FMU (co-simulation only)\", function);
    say(instance, fmi3Error, message);
    return fmi3Error;
}}

/* A value reference this FMU does not have (for this type). */
static fmi3Status unknown(Instance *m, const char *function, fmi3ValueReference vr)
{{
    char message[160];
    snprintf(message, sizeof message, \"%.60s: no variable of this type has value reference %lu\", function,
            (unsigned long)vr);
    say(m, fmi3Error, message);
    return fmi3Error;
}}

/* Outputs with no estimate: not numbers, no alarm, no candidate. */
static void no_estimate(Instance *m)
{{
    int k;
    m->ready = false;
    m->out.at = NAN;
    for (k = 0; k < {r}; k++) {{
        m->out.residuals[k] = NAN;
        m->out.thresholds[k] = NAN;
        m->out.alarms[k] = 0;
    }}
    m->candidates[0] = '\\0';
}}

/* The start values of the model description. */
static void defaults(Instance *m)
{{
    int k;
    m->params = {id}_default_params;
{defaults}    m->time = 0.0;
    m->sizing = false;
    for (k = 0; k < (int)(sizeof m->size_out / sizeof m->size_out[0]); k++)
        m->size_out[k].value = m->size_out[k].half_width = m->size_out[k].misfit = NAN;
    no_estimate(m);
}}

/* Whether a fixed parameter may be set now: before initialisation ends. */
static bool settable(Instance *m, const char *function)
{{
    if (m->mode == INSTANTIATED || m->mode == INITIALIZATION)
        return true;
    {{
        char message[160];
        snprintf(message, sizeof message, \"%.60s: a parameter is fixed once initialisation ends\", function);
        say(m, fmi3Error, message);
    }}
    return false;
}}
"
    )
}

/// The size estimates: set up at the end of initialisation, pushed at each step.
fn sizes(id: &str, r: usize, sized: usize) -> String {
    format!(
        "
/* Sets up the size estimates switched on, over the generator as set up: each residual weighed
   by its noise level, else its decision level over 3. Without either for some residual, no
   size is estimated, and the logger says why. 0 where a setting is refused. */
static int start_sizes(Instance *m)
{{
    double noise[{r_dim}];
    int k, status, any = 0;
    char message[200];
    m->sizing = false;
    for (k = 0; k < {sized}; k++)
        any |= m->size_on[k];
    if (!any)
        return 1;
    for (k = 0; k < {r}; k++) {{
        noise[k] = m->noise[k] > 0.0 ? m->noise[k] : m->levels[k] > 0.0 ? m->levels[k] / 3.0 : -1.0;
        if (noise[k] > 0.0)
            continue;
        if (m->log != NULL) {{
            snprintf(message, sizeof message, \"no fault size is estimated: %.40s has neither a noise level \"
                     \"(size.noise.%.40s) nor a decision level\", {id}_residual_names[k], {id}_residual_names[k]);
            m->log(m->environment, fmi3Warning, \"logStatusWarning\", message);
        }}
        return 1;
    }}
    for (k = 0; k < {sized}; k++) {{
        if (!m->size_on[k])
            continue;
        status = {id}_size_init(&m->sizes[k], &m->generator, places[k], noise, m->size_memory);
        if (status != BGC_OK) {{
            say(m, fmi3Error, {id}_status_text(status));
            return 0;
        }}
        {id}_size_set_correlation(&m->sizes[k], m->window);
        {id}_size_set_settling(&m->sizes[k], m->integration > 0 ? m->integration : {settling});
        m->size_out[k] = {id}_size_estimate(&m->sizes[k]);
    }}
    m->sizing = true;
    return 1;
}}

/* Pushes the sample at t to each size estimate switched on. */
static void push_sizes(Instance *m, double t)
{{
    int k;
    for (k = 0; m->sizing && k < {sized}; k++) {{
        if (!m->size_on[k])
            continue;
        {id}_size_push(&m->sizes[k], t, m->raw);
        m->size_out[k] = {id}_size_estimate(&m->sizes[k]);
    }}
}}
",
        r_dim = r.max(1),
        // From the start, the reference's default window stands in for the settling.
        settling = super::variables::DEFAULT_INTEGRATION,
    )
}

/// Instantiation, initialisation, termination, reset, freeing.
fn lifecycle(id: &str, r: usize) -> String {
    format!(
        "
const char *fmi3GetVersion(void)
{{
    return \"3.0\";
}}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{{
    Instance *m = instance;
    (void)nCategories;
    (void)categories;
    if (m == NULL)
        return fmi3Error;
    m->logging = loggingOn;
    return fmi3OK;
}}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{{
    Instance *m;
    const char *name = instanceName != NULL ? instanceName : \"\";
    (void)resourcePath;
    (void)visible;
    (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (instantiationToken == NULL || strcmp(instantiationToken, TOKEN) != 0) {{
        if (logMessage != NULL)
            logMessage(instanceEnvironment, fmi3Error, \"logStatusError\",
                       \"the instantiation token is not this FMU's: its model description and \"
                       \"binary come from different models\");
        return NULL;
    }}
    if (eventModeUsed) {{
        if (logMessage != NULL)
            logMessage(instanceEnvironment, fmi3Error, \"logStatusError\",
                       \"this FMU has no event mode\");
        return NULL;
    }}
    m = calloc(1, sizeof(Instance));
    if (m == NULL)
        return NULL;
    m->name = malloc(strlen(name) + 1);
    if (m->name == NULL) {{
        free(m);
        return NULL;
    }}
    strcpy(m->name, name);
    m->environment = instanceEnvironment;
    m->log = logMessage;
    m->logging = loggingOn;
    m->mode = INSTANTIATED;
    defaults(m);
    return m;
}}

void fmi3FreeInstance(fmi3Instance instance)
{{
    Instance *m = instance;
    if (m == NULL)
        return;
    free(m->name);
    free(m);
}}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{{
    Instance *m = instance;
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (m == NULL || m->mode != INSTANTIATED)
        return refuse(instance, \"fmi3EnterInitializationMode out of the instantiated state\");
    m->time = startTime;
    m->mode = INITIALIZATION;
    return fmi3OK;
}}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{{
    Instance *m = instance;
    int status, k;
    if (m == NULL || m->mode != INITIALIZATION)
        return refuse(instance, \"fmi3ExitInitializationMode out of initialisation\");
    status = {id}_init(&m->generator, &m->params, m->step, m->window, m->degree);
    if (status == BGC_OK) {{
        if (m->integration == 0)
            {id}_integrate_from_start(&m->generator);
        else
            status = {id}_set_integration_window(&m->generator, m->integration);
    }}
    if (status != BGC_OK) {{
        say(m, fmi3Error, {id}_status_text(status));
        return fmi3Error;
    }}
    for (k = 0; k < {r}; k++)
        {id}_set_threshold(&m->generator, k, m->levels[k] < 0.0 ? NAN : m->levels[k]);
    {id}_set_debounce(&m->generator, m->debounce < 1 ? 1u : (unsigned)m->debounce);
    {id}_set_adaptive(&m->generator, m->adaptive);
    no_estimate(m);
    if (!start_sizes(m))
        return fmi3Error;
    m->mode = STEPPING;
    return fmi3OK;
}}

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{{
    Instance *m = instance;
    if (m == NULL || m->mode != STEPPING)
        return refuse(instance, \"fmi3EnterStepMode (without event mode, step mode follows initialisation)\");
    return fmi3OK;
}}

fmi3Status fmi3Terminate(fmi3Instance instance)
{{
    Instance *m = instance;
    if (m == NULL)
        return fmi3Error;
    m->mode = TERMINATED;
    return fmi3OK;
}}

fmi3Status fmi3Reset(fmi3Instance instance)
{{
    Instance *m = instance;
    if (m == NULL)
        return fmi3Error;
    m->mode = INSTANTIATED;
    defaults(m);
    return fmi3OK;
}}
"
    )
}

/// The C type of an FMI type's values.
fn c_type(ty: &str) -> String {
    format!("fmi3{ty}")
}

/// Whether the variable is of the FMI type named `ty`.
fn of_type(v: &Variable, ty: &str) -> bool {
    v.ty.name() == ty
}

/// `fmi3GetTY`: each variable of the type by its reference.
fn getter(ty: &str, vars: &[Variable]) -> String {
    let mut cases = String::new();
    for v in vars.iter().filter(|v| of_type(v, ty)) {
        let value = match (v.ty, &v.role) {
            (Type::Boolean, _) => format!("{} != 0", v.role.place()),
            (Type::Int32, _) => format!("(fmi3Int32){}", v.role.place()),
            _ => v.role.place(),
        };
        let _ = writeln!(
            cases,
            "        case {}:\n            values[i] = {value};\n            break;",
            v.reference
        );
    }
    format!(
        "
fmi3Status fmi3Get{ty}(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                      size_t nValueReferences, {ct} values[], size_t nValues)
{{
    Instance *m = instance;
    size_t i;
    if (m == NULL)
        return fmi3Error;
    if (nValues != nValueReferences)
        return refuse(instance, \"fmi3Get{ty} of arrays (every variable is a scalar)\");
    for (i = 0; i < nValueReferences; i++) {{
        switch (valueReferences[i]) {{
{cases}        default:
            (void)values;
            return unknown(m, \"fmi3Get{ty}\", valueReferences[i]);
        }}
    }}
    return fmi3OK;
}}
",
        ct = c_type(ty),
    )
}

/// `fmi3SetTY`: inputs at any time before termination, parameters before initialisation
/// ends; outputs and time are not set.
fn setter(ty: &str, vars: &[Variable]) -> String {
    let mut cases = String::new();
    for v in vars.iter().filter(|v| of_type(v, ty)) {
        let guard = match v.causality {
            Causality::Input => String::new(),
            Causality::Parameter => format!(
                "            if (!settable(m, \"fmi3Set{ty}\"))\n                return fmi3Error;\n"
            ),
            _ => continue,
        };
        let value = match (&v.role, v.ty) {
            (
                Role::Integration | Role::Window | Role::Degree | Role::Debounce | Role::SizeMemory,
                _,
            ) => "(int)values[i]".to_string(),
            _ => "values[i]".to_string(),
        };
        let _ = writeln!(
            cases,
            "        case {}:\n{guard}            {} = {value};\n            break;",
            v.reference,
            v.role.place()
        );
    }
    format!(
        "
fmi3Status fmi3Set{ty}(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                      size_t nValueReferences, const {ct} values[], size_t nValues)
{{
    Instance *m = instance;
    size_t i;
    if (m == NULL)
        return fmi3Error;
    if (nValues != nValueReferences)
        return refuse(instance, \"fmi3Set{ty} of arrays (every variable is a scalar)\");
    if (m->mode == TERMINATED)
        return refuse(instance, \"fmi3Set{ty} after termination\");
    for (i = 0; i < nValueReferences; i++) {{
        switch (valueReferences[i]) {{
{cases}        default:
            (void)values;
            return unknown(m, \"fmi3Set{ty} (inputs and parameters only)\", valueReferences[i]);
        }}
    }}
    return fmi3OK;
}}
",
        ct = c_type(ty),
    )
}

/// `fmi3DoStep`: one sample pushed, the outputs updated.
fn do_step(id: &str, r: usize) -> String {
    format!(
        "
fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{{
    Instance *m = instance;
    int alarms[{r_dim}], found[{upper}_COMPONENTS > 0 ? {upper}_COMPONENTS : 1], count, k;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (m == NULL || m->mode != STEPPING)
        return refuse(instance, \"fmi3DoStep out of step mode\");
    if (!(fabs(communicationStepSize - m->step) <= 1e-6 * m->step)) {{
        char message[200];
        snprintf(message, sizeof message, \"a communication step of %.17g s, where the record's step (the parameter \"
                         \"record.step) is %.17g s: the estimators need the record's uniform step\",
                communicationStepSize, m->step);
        say(m, fmi3Error, message);
        return fmi3Error;
    }}
    push_sizes(m, currentCommunicationPoint);
    if ({id}_push(&m->generator, currentCommunicationPoint, m->raw, &m->out)) {{
        m->ready = true;
        for (k = 0; k < {r}; k++)
            alarms[k] = m->out.alarms[k];
        count = {id}_candidates(alarms, found);
        m->candidates[0] = '\\0';
        for (k = 0; k < count; k++) {{
            if (k > 0)
                strcat(m->candidates, \" \");
            strcat(m->candidates, {id}_component_names[found[k]]);
        }}
    }} else {{
        no_estimate(m);
    }}
    m->time = currentCommunicationPoint + communicationStepSize;
    if (eventHandlingNeeded != NULL)
        *eventHandlingNeeded = false;
    if (terminateSimulation != NULL)
        *terminateSimulation = false;
    if (earlyReturn != NULL)
        *earlyReturn = false;
    if (lastSuccessfulTime != NULL)
        *lastSuccessfulTime = m->time;
    return fmi3OK;
}}
",
        r_dim = r.max(1),
        upper = id.to_ascii_uppercase(),
    )
}
