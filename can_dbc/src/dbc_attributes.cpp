// DBC parser, the attributes and value descriptions: BA_DEF_, BA_DEF_DEF_, BA_ (checked against
// their definitions), VAL_ and SIG_VALTYPE_.
#include "dbc_parser.hpp"

namespace emadiag::can::detail {

void Parser::attribute_definition() {
    next();
    AttributeDefinition d;
    if (peek().kind == Tok::Ident) {
        const Token ot = next();
        if (ot.text == "BU_") d.object = AttributeObject::Node;
        else if (ot.text == "BO_") d.object = AttributeObject::Message;
        else if (ot.text == "SG_") d.object = AttributeObject::Signal;
        else if (ot.text == "EV_") d.object = AttributeObject::EnvVar;
        else throw SyntaxError{ot.line, ot.col, "expected BU_, BO_, SG_, EV_ or the attribute name, found '" + ot.text + "'"};
    }
    const Token name_tok = peek();
    d.name = string_lit("attribute name");
    const Token tt = peek();
    const std::string type = ident("attribute type INT, HEX, FLOAT, STRING or ENUM");
    if (type == "INT" || type == "HEX" || type == "FLOAT") {
        d.type = type == "INT" ? AttributeType::Int : type == "HEX" ? AttributeType::Hex : AttributeType::Float;
        d.minimum = number("attribute minimum");
        d.maximum = number("attribute maximum");
    } else if (type == "STRING") {
        d.type = AttributeType::String;
    } else if (type == "ENUM") {
        d.type = AttributeType::Enum;
        d.enum_values.push_back(string_lit("enum value"));
        while (accept_punct(",")) d.enum_values.push_back(string_lit("enum value"));
    } else {
        throw SyntaxError{tt.line, tt.col, "attribute '" + d.name + "': unknown type '" + type + "' (expected INT, HEX, FLOAT, STRING or ENUM)"};
    }
    expect_semicolon();
    if (db_.attribute_definitions.count(d.name)) soft(name_tok, "attribute '" + d.name + "' is defined twice", "the later definition kept");
    db_.attribute_definitions[d.name] = std::move(d);
}

Parser::Literal Parser::attribute_literal(const AttributeDefinition* def, const Token& at) {
    Literal lit;
    AttributeValue& v = lit.value;
    bool& skip = lit.skip;
    if (peek().kind == Tok::String) {
        v.is_string = true;
        v.text = next().text;
    } else {
        v.number = number("attribute value");
        v.text = at.text;
    }
    if (def == nullptr) {
        skip = true;
        return lit;
    }
    const bool numeric = def->type == AttributeType::Int || def->type == AttributeType::Hex || def->type == AttributeType::Float;
    if (numeric && v.is_string) {
        soft(at, "attribute '" + def->name + "' is numeric, found string \"" + v.text + "\"", "kept as a string");
    } else if (def->type == AttributeType::String && !v.is_string) {
        soft(at, "attribute '" + def->name + "' is a STRING, found number " + at.text, "kept as a number");
    } else if (numeric && (def->minimum != 0 || def->maximum != 0) && (v.number < def->minimum || v.number > def->maximum)) {
        soft(at, "attribute '" + def->name + "': value " + at.text + " outside [" + std::to_string(def->minimum) + ", " + std::to_string(def->maximum) + "]",
             "kept as written");
    } else if (def->type == AttributeType::Enum) {
        if (v.is_string) {
            bool found = false;
            for (std::size_t i = 0; i < def->enum_values.size(); ++i)
                if (def->enum_values[i] == v.text) {
                    v.number = static_cast<double>(i);
                    found = true;
                }
            if (!found) {
                soft(at, "attribute '" + def->name + "': \"" + v.text + "\" is not one of its ENUM values", "value skipped");
                skip = true;
            }
        } else if (v.number < 0 || v.number >= static_cast<double>(def->enum_values.size())) {
            soft(at, "attribute '" + def->name + "': ENUM index " + at.text + " outside 0.." + std::to_string(def->enum_values.size() - 1),
                 "value skipped");
            skip = true;
        } else {
            v.text = def->enum_values[static_cast<std::size_t>(v.number)];
        }
    }
    return lit;
}

void Parser::attribute_default() {
    next();
    const Token nt = peek();
    const std::string name = string_lit("attribute name");
    auto it = db_.attribute_definitions.find(name);
    if (it == db_.attribute_definitions.end()) soft(nt, "BA_DEF_DEF_ for undefined attribute '" + name + "'", "statement skipped");
    const Token vt = peek();
    Literal v = attribute_literal(it == db_.attribute_definitions.end() ? nullptr : &it->second, vt);
    expect_semicolon();
    if (it != db_.attribute_definitions.end() && !v.skip) it->second.default_value = v.value;
}

void Parser::attribute_value() {
    next();
    const Token nt = peek();
    const std::string name = string_lit("attribute name");
    auto it = db_.attribute_definitions.find(name);
    const AttributeDefinition* def = it == db_.attribute_definitions.end() ? nullptr : &it->second;
    if (def == nullptr) soft(nt, "BA_ for undefined attribute '" + name + "'", "statement skipped");
    std::map<std::string, AttributeValue>* target = &db_.network_attributes;
    AttributeObject object = AttributeObject::Network;
    std::map<std::string, AttributeValue> discard;
    if (peek().kind == Tok::Ident) {
        const std::string what = next().text;
        if (what == "BU_") {
            object = AttributeObject::Node;
            ident("node name");
            target = &discard;
        } else if (what == "BO_") {
            object = AttributeObject::Message;
            const Token at = peek();
            Message* m = message_by_id(at, unsigned_int("message id"));
            target = m ? &m->attributes : &discard;
        } else if (what == "SG_") {
            object = AttributeObject::Signal;
            const Token at = peek();
            Message* m = message_by_id(at, unsigned_int("message id"));
            const Token sat = peek();
            Signal* s = signal_of(m, sat, ident("signal name"));
            target = s ? &s->attributes : &discard;
        } else if (what == "EV_") {
            object = AttributeObject::EnvVar;
            ident("environment variable name");
            target = &discard;
        } else {
            fail(nt, "BU_, BO_, SG_ or EV_");
        }
    }
    if (def != nullptr && def->object != object) {
        soft(nt, "attribute '" + name + "' is not defined for this kind of object", "statement skipped");
        target = &discard;
    }
    const Token vt = peek();
    Literal v = attribute_literal(def, vt);
    expect_semicolon();
    if (def != nullptr && !v.skip) (*target)[name] = v.value;
}

void Parser::value_descriptions() {
    next();
    if (peek().kind == Tok::Ident) {  // VAL_ of an environment variable
        skip_to_semicolon();
        return;
    }
    const Token at = peek();
    Message* m = message_by_id(at, unsigned_int("message id"));
    const Token sat = peek();
    const std::string sname = ident("signal name");
    Signal* s = signal_of(m, sat, sname);
    std::map<std::int64_t, std::string> table;
    while (peek().kind == Tok::Number) {
        const Token vt = peek();
        const std::int64_t v = value_key("value");
        const std::string d = string_lit("value description");
        if (table.count(v)) error(vt, "signal '" + sname + "': value " + vt.text + " described twice");
        table[v] = d;
    }
    expect_semicolon();
    if (s) s->value_table = std::move(table);
}

void Parser::signal_value_type() {
    next();
    const Token at = peek();
    Message* m = message_by_id(at, unsigned_int("message id"));
    const Token sat = peek();
    Signal* s = signal_of(m, sat, ident("signal name"));
    accept_punct(":");
    const Token vt = peek();
    const std::uint64_t t = unsigned_int("value type");
    expect_semicolon();
    if (t > 2) {
        error(vt, "SIG_VALTYPE_ " + vt.text + " is not 0 (integer), 1 (float32) or 2 (float64)");
        return;
    }
    if (s == nullptr) return;
    s->value_type = t == 1 ? ValueType::Float32 : t == 2 ? ValueType::Float64 : ValueType::Integer;
    const std::uint32_t need = t == 1 ? 32 : t == 2 ? 64 : s->length;
    if (s->length != need)
        error(vt, "signal '" + s->name + "' is " + std::to_string(s->length) + " bits but SIG_VALTYPE_ " + vt.text + " needs " + std::to_string(need));
}

}  // namespace emadiag::can::detail
