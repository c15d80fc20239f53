struct type_5 {
    member: array<f32>,
}

struct type_9 {
    member: array<i32>,
}

var<private> global: vec3<u32>;
@group(0) @binding(0) 
var<storage> global_1: type_5;
@group(0) @binding(1) 
var<storage, read_write> global_2: type_9;

fn function_() {
    var phi_175_: i32;
    var phi_63_: u32;
    var phi_187_: bool;
    var phi_104_: u32;
    var phi_64_: u32;
    var phi_106_: bool;
    var phi_107_: bool;
    var phi_192_: bool;
    var phi_161_: bool;

    switch bitcast<i32>(0u) {
        default: {
            let _e18 = global;
            let _e20 = arrayLength((&global_1.member));
            let _e24 = (_e18.x < arrayLength((&global_2.member)));
            if _e24 {
                if (_e18.x < _e20) {
                } else {
                    break;
                }
                let _e28 = global_1.member[_e18.x];
                if (_e28 > 0.1f) {
                    phi_175_ = 1i;
                } else {
                    phi_175_ = select(0i, -1i, (_e28 < -0.1f));
                }
                let _e33 = phi_175_;
                phi_63_ = 2u;
                loop {
                    let _e35 = phi_63_;
                    let _e36 = (_e35 < _e20);
                    if _e36 {
                        if _e36 {
                        } else {
                            phi_192_ = true;
                            phi_161_ = bool();
                            break;
                        }
                        let _e39 = global_1.member[_e35];
                        let _e40 = (_e35 - 2u);
                        if (_e40 < _e20) {
                        } else {
                            phi_192_ = true;
                            phi_161_ = bool();
                            break;
                        }
                        let _e44 = global_1.member[_e40];
                        if _e36 {
                        } else {
                            phi_192_ = true;
                            phi_161_ = bool();
                            break;
                        }
                        let _e47 = abs(_e39);
                        if (_e47 != _e47) {
                            phi_187_ = true;
                        } else {
                            phi_187_ = (1f >= _e47);
                        }
                        let _e51 = phi_187_;
                        let _e54 = (abs((_e39 - _e44)) > (0.0001f * select(_e47, 1f, _e51)));
                        if _e54 {
                            phi_104_ = u32();
                        } else {
                            phi_104_ = (_e35 + 1u);
                        }
                        let _e57 = phi_104_;
                        phi_64_ = _e57;
                        phi_106_ = select(true, false, _e54);
                        phi_107_ = _e54;
                    } else {
                        phi_64_ = u32();
                        phi_106_ = false;
                        phi_107_ = false;
                    }
                    let _e60 = phi_64_;
                    let _e62 = phi_106_;
                    let _e64 = phi_107_;
                    continue;
                    continuing {
                        phi_63_ = _e60;
                        phi_192_ = false;
                        phi_161_ = _e64;
                        break if !(_e62);
                    }
                }
                let _e67 = phi_192_;
                let _e69 = phi_161_;
                if _e67 {
                    break;
                }
                if _e24 {
                } else {
                    break;
                }
                global_2.member[_e18.x] = (_e33 + bitcast<i32>(select(0u, 2u, select(true, false, _e69))));
            }
            break;
        }
    }
    return;
}

@compute @workgroup_size(64, 1, 1) 
fn main_cs(@builtin(global_invocation_id) param: vec3<u32>) {
    global = param;
    function_();
}
