!> The &model kinds written as equations (mlid_deck): the text of an
!> equations model (states and derivatives, inputs, parameters with start
!> values, definitions, outputs) for mlid_equations, the rigid-body lines
!> of kind 'sixdof' around the deck's definitions, the kinematic model of
!> kind 'flight_path', and the params entries ('NAME = value').
submodule (mlid_deck) mlid_deck_equations
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_equations, only: equations_t, equations_create, equations_text_codes
  use mlid_sixdof, only: sixdof_parts
  use mlid_flightpath, only: flightpath_text, FLIGHTPATH_OUTPUTS, FLIGHTPATH_INPUTS
  use mlid_expr, only: split_definition, expr_t, expr_compile, expr_eval
  use mlid_long_text, only: longitudinal_text
  use mlid_layout, only: layout_table_t, layout_of, default_label
  use mlid_model_factory, only: MODEL_EQUATIONS
  use mlid_params, only: no_ties
  implicit none

contains

  !> An equations model's text (mlid_equations) from the deck: the states
  !> and their derivatives, inputs, parameters ('NAME' or 'NAME = start
  !> value', in the order of p), definitions and outputs.
  module procedure equations_text
    character(len=:), allocatable :: text
    character(len=NAMELEN) :: name
    character(len=NAMELEN), allocatable :: pnames(:)
    integer :: k

    text = ''
    allocate (pstart(0))
    if (has_gap(c, 'state_names', states) .or. has_gap(c, 'xdot', xdot) .or. &
        has_gap(c, 'input_names', inputs) .or. has_gap(c, 'output_names', ynames) .or. &
        has_gap(c, 'outputs', outputs) .or. has_gap(c, 'definitions', definitions) .or. &
        has_gap(c, 'params', params)) return
    if (count(len_trim(states) > 0) /= count(len_trim(xdot) > 0)) then
      call fail(c, 'group &model: the equations model needs one xdot per state_names entry')
      return
    end if
    if (any(len_trim([xdot, outputs, definitions, params]) == TIELEN)) then
      call fail(c, 'group &model: an equation is longer than '//itoa(TIELEN - 1)//' characters')
      return
    end if
    do k = 1, count(len_trim(inputs) > 0)
      text = text//'u '//trim(inputs(k))//achar(10)
    end do
    call param_entries(c, pack(params, index(params, '[') == 0), pnames, pstart)
    if (c%status /= MLID_OK) return
    do k = 1, size(pnames)
      text = text//'p '//trim(pnames(k))//achar(10)
    end do
    if (present(pre)) text = text//pre
    do k = 1, count(len_trim(definitions) > 0)      ! 'NAME(v, ...) = breakpoints': a table
      text = text//trim(merge('t', 'l', index(definitions(k), '(') > 0 .and. &
                              scan(definitions(k), '=(') == index(definitions(k), '(')))// &
             ' '//trim(definitions(k))//achar(10)
    end do
    if (present(post)) text = text//post
    do k = 1, count(len_trim(xdot) > 0)
      text = text//'x '//trim(states(k))//' = '//trim(xdot(k))//achar(10)
    end do
    do k = 1, count(len_trim(outputs) > 0)
      name = ynames(k)
      if (len_trim(name) == 0) name = 'y'//itoa(k)
      text = text//'y '//trim(name)//' = '//trim(outputs(k))//achar(10)
    end do
    c%iconst = equations_text_codes(text)
    call table_starts(c, pack(params, index(params, '[') > 0), pstart)
  end procedure equations_text

  !> The start values of the tables' values (params entries 'NAME[i,j] =
  !> value', each value's once; the others start at 0) after those of the
  !> params (pstart): the order of p.  A model that cannot be made is left
  !> for the kind's own check to say so.
  subroutine table_starts(c, entries, pstart)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: entries(:)
    real(wp), allocatable, intent(inout) :: pstart(:)
    type(equations_t) :: eqs
    character(len=msg_len) :: iomsg
    real(wp), allocatable :: full(:)
    logical, allocatable :: given(:)
    real(wp) :: v
    integer :: k, j, ios, eq

    call equations_create(c%iconst, [real(wp) ::], eqs, ios, iomsg)
    if (ios /= MLID_OK) return
    allocate (full(eqs%np), given(eqs%np))
    full = 0.0_wp
    full(1:size(pstart)) = pstart
    given = .false.
    do k = 1, size(entries)
      eq = index(entries(k), '=')
      j = 0
      if (eq > 0) j = findloc(eqs%pnames, trim(adjustl(entries(k)(1:eq - 1))), 1)
      if (j == 0) then
        call fail(c, 'group &model: params entry '''//trim(entries(k))//''' is not '// &
                  '''NAME[i] = value'' of a table''s value')
        return
      end if
      if (given(j)) then
        call fail(c, 'group &model: params entry '''//trim(entries(k))//''' gives '// &
                  trim(eqs%pnames(j))//' a start value a second time')
        return
      end if
      call entry_value(c, entries(k), entries(k)(eq + 1:), v)
      if (c%status /= MLID_OK) return
      full(j) = v
      given(j) = .true.
    end do
    call move_alloc(full, pstart)
  end subroutine table_starts

  !> kind = 'longitudinal' with tables (definitions 'C_Lalpha(alpha) = 0 0.1'):
  !> the model written as equations (mlid_long_text, as Python's
  !> with_tables), its parameters the coefficients not tabled, then the
  !> tables' values; a value starts at its params entry ('C_Lalpha[2] =
  !> 3.1'), else at its coefficient's start value (cd, cl, cm).  The other
  !> blocks (x0, bias, r, delay, ...) carry over; process noise it has none.
  module procedure longitudinal_tables
    type(layout_table_t) :: eq
    character(len=:), allocatable :: text
    character(len=msg_len) :: iomsg
    real(wp), allocatable :: theta(:), pstart(:)
    character(len=32), allocatable :: labels(:)     ! default_label's
    integer :: ios, b, o, n, k

    if (has_gap(c, 'definitions', definitions) .or. has_gap(c, 'params', params)) return
    if (any(len_trim([definitions, params]) == TIELEN)) then
      call fail(c, 'group &model: an entry is longer than '//itoa(TIELEN - 1)//' characters')
      return
    end if
    k = findloc(len_trim(params) > 0 .and. index(params, '[') == 0, .true., 1)
    if (k > 0) then
      call fail(c, 'group &model: params entry '''//trim(params(k))//''' is not ''NAME[i] = '// &
                'value'' of a table''s value (kind = ''longitudinal'': its coefficients start in '// &
                'cd, cl, cm)')
      return
    end if
    if (any(c%theta([block_idx(lt, 'q'), block_idx(lt, 's')]) /= 0.0_wp)) then
      call fail(c, 'group &model: kind = ''longitudinal'' with tables is written as equations, '// &
                'which have no process noise: q and s must be zero')
      return
    end if
    call longitudinal_text(c%iconst, c%rconst, pack(definitions, len_trim(definitions) > 0), &
                           text, ios, iomsg)
    if (ios == MLID_OK) then
      c%iconst = equations_text_codes(text)
      c%rconst = [real(wp) ::]
      call layout_of(MODEL_EQUATIONS, c%nx, c%nu, c%ny, 0, c%iconst, c%rconst, eq, ios, iomsg)
    end if
    if (ios /= MLID_OK) then
      call fail(c, 'group &model: '//trim(iomsg))
      return
    end if
    allocate (pstart(eq%np), theta(eq%nth))
    labels = [(default_label(lt, b), b=1, lt%np)]
    do k = 1, eq%np                       ! 'C_mq' or a value 'C_Lalpha[2]': its coefficient's
      n = scan(eq%pnames(k)//'[', '[')
      pstart(k) = c%theta(findloc(labels, eq%pnames(k)(1:n - 1), 1))
    end do
    call table_starts(c, pack(params, len_trim(params) > 0), pstart)
    if (c%status /= MLID_OK) return
    theta = 0.0_wp
    theta(1:eq%np) = pstart
    do b = 1, eq%nblock                  ! x0, bias, r, delay, udelay, stab, p0
      o = findloc(lt%key, eq%key(b), 1)
      if (eq%key(b) == 'p' .or. o == 0) cycle
      if (size(block_idx(eq, eq%key(b))) == size(block_idx(lt, lt%key(o)))) &
        theta(block_idx(eq, eq%key(b))) = c%theta(block_idx(lt, lt%key(o)))
    end do
    call move_alloc(theta, c%theta)
    deallocate (c%isfree)
    allocate (c%isfree(eq%nth), source=0)
    c%tie = no_ties(eq%nth)
    c%mkind = MODEL_EQUATIONS
    c%nw = 0
    lt = eq
  end procedure longitudinal_tables

  !> The indices in theta of block key of layout lt.
  function block_idx(lt, key) result(idx)
    type(layout_table_t), intent(in) :: lt
    character(len=*), intent(in) :: key
    integer, allocatable :: idx(:)
    integer :: b, k
    b = findloc(lt%key, key, 1)
    idx = [(lt%off(b) + k, k=1, lt%rows(b)*merge(1, lt%cols(b), lt%cols(b) < 0))]
  end function block_idx

  !> kind = 'sixdof': the rigid-body lines of mlid_sixdof around the deck's
  !> definitions, and the state equations (xs) in the order of state_names.
  module procedure sixdof_deck
    character(len=:), allocatable :: lines
    character(len=NAMELEN) :: defined(size(definitions))
    character(len=msg_len) :: iomsg
    integer :: k, a, b, ios

    allocate (xs(0))
    if (any(len_trim(xdot) > 0)) then
      call fail(c, 'group &model: kind = ''sixdof'' writes the state equations itself (no xdot)')
      return
    end if
    defined = ''
    do k = 1, size(definitions)
      a = scan(definitions(k), '=(')           ! a definition's name, or a table's
      if (a > 1) defined(k) = adjustl(definitions(k)(1:a - 1))
    end do
    call sixdof_parts(constants, pack(states, len_trim(states) > 0), &
                      pack(inputs, len_trim(inputs) > 0), pack(defined, len_trim(defined) > 0), &
                      pre, post, lines, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(c, 'group &model: '//trim(iomsg))
      return
    end if
    a = 1                                   ! 'x NAME = EXPR' lines -> the EXPRs
    do while (a < len(lines))
      b = a + index(lines(a:), achar(10)) - 1
      k = a + index(lines(a:b), '=') + 1    ! the EXPR: lines(k:b-1)
      if (b - k > TIELEN) then
        write (iomsg, '(a,i0,a,i0,a)') 'group &model: a state equation of kind = ''sixdof'' has ', &
          b - k, ' characters, more than the ', TIELEN, ' an equation may have'
        call fail(c, trim(iomsg))
        return
      end if
      xs = [character(len=TIELEN) :: xs, lines(k:b - 1)]
      a = b + 1
    end do
  end procedure sixdof_deck

  !> The kinds whose model is a text of equations (mlid_equations).
  module procedure written_as_equations
    written_as_equations = any(to_lower(kind) == [character(len=11) :: 'equations', 'sixdof', &
                                                  'flight_path'])
  end procedure written_as_equations

  !> kind = 'flight_path': the kinematic model of mlid_flightpath with the
  !> corrections params names (start values there), the outputs of
  !> output_names (all seven when none) and its own states and inputs.
  module procedure flightpath_deck
    character(len=NAMELEN), allocatable :: pnames(:)
    character(len=:), allocatable :: text
    character(len=msg_len) :: iomsg
    integer :: ios

    allocate (pstart(0))
    if (any(len_trim(states) > 0) .or. any(len_trim(xdot) > 0) .or. any(len_trim(inputs) > 0) &
        .or. any(len_trim(outputs) > 0) .or. any(len_trim(definitions) > 0)) then
      call fail(c, 'group &model: kind = ''flight_path'' writes its states, inputs and '// &
                'equations itself (no state_names, xdot, input_names, outputs, definitions)')
      return
    end if
    if (has_gap(c, 'params', params) .or. has_gap(c, 'output_names', ynames)) return
    call param_entries(c, params, pnames, pstart)
    if (c%status /= MLID_OK) return
    if (all(len_trim(ynames) == 0)) ynames(1:size(FLIGHTPATH_OUTPUTS)) = FLIGHTPATH_OUTPUTS
    call flightpath_text(constants, pnames, &
                         pack(ynames, len_trim(ynames) > 0), text, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(c, 'group &model: '//trim(iomsg))
      return
    end if
    inputs(1:size(FLIGHTPATH_INPUTS)) = FLIGHTPATH_INPUTS
    c%iconst = equations_text_codes(text)
    c%flight_path = .true.
  end procedure flightpath_deck

  !> The params entries' names and start values, in order.
  subroutine param_entries(c, params, names, values)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: params(:)
    character(len=NAMELEN), allocatable, intent(out) :: names(:)
    real(wp), allocatable, intent(out) :: values(:)
    integer :: k, n
    n = count(len_trim(params) > 0)
    allocate (names(n), values(n))
    do k = 1, n
      call param_entry(c, params(k), names(k), values(k))
      if (c%status /= MLID_OK) return
    end do
  end subroutine param_entries

  !> A params entry: 'NAME' (start value 0) or 'NAME = value', the value an
  !> expression of numbers ('-3/2', '2*pi'), never read loosely.
  subroutine param_entry(c, entry, name, v)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: entry
    character(len=*), intent(out) :: name
    real(wp), intent(out) :: v
    character(len=:), allocatable :: rhs
    character(len=msg_len) :: iomsg
    integer :: ios

    v = 0.0_wp
    if (index(entry, '=') == 0) then
      call split_definition(trim(entry)//' = 0', name, rhs, ios, iomsg)
    else
      call split_definition(entry, name, rhs, ios, iomsg)
    end if
    if (ios /= MLID_OK) then
      call fail(c, 'group &model: params entry '''//trim(entry)//''': '//trim(iomsg))
    else if (index(entry, '=') > 0) then
      call entry_value(c, entry, rhs, v)
    end if
  end subroutine param_entry

  !> The value rhs of params entry entry: an expression of numbers.
  subroutine entry_value(c, entry, rhs, v)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: entry, rhs
    real(wp), intent(out) :: v
    call number_value(c, 'group &model: params entry', entry, rhs, v)
  end subroutine entry_value

  !> The value rhs of an entry 'NAME = value': an expression of numbers
  !> ('-3/2', '2*pi'), finite, never read loosely; what names the entry's
  !> list in the message.
  module procedure number_value
    character(len=msg_len) :: iomsg
    type(expr_t) :: ex
    real(wp) :: none(1, 0), val(1)
    integer :: ios

    v = 0.0_wp
    call expr_compile(rhs, [character(len=1) ::], ex, ios, iomsg, noun='variable')
    if (ios == MLID_OK) then
      call expr_eval(ex, none, val)
      v = val(1)
      if (.not. ieee_is_finite(v)) then
        ios = MLID_ERR_INPUT
        iomsg = 'the value is not finite'
      end if
    end if
    if (ios /= MLID_OK) call fail(c, what//' '''//trim(entry)//''': '//trim(iomsg))
  end procedure number_value

  !> Whether a list has a blank entry before a filled one (said in one line).
  logical function has_gap(c, what, list)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: what, list(:)
    integer :: k
    has_gap = .false.
    k = findloc(len_trim(list) == 0, .true., 1)
    if (k == 0) return
    has_gap = any(len_trim(list(k + 1:)) > 0)
    if (has_gap) call fail(c, 'group &model: '//what//'('//itoa(k)//') is empty, and an '// &
                           'entry after it is not')
  end function has_gap

end submodule mlid_deck_equations
