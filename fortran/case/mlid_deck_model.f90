!> The reader of a deck's &model group (mlid_deck): the kind and its
!> sizes (a built-in model's own), the parameter vector block by block
!> (matrices row by row), the free parameters and their labels, ties,
!> input hold and substeps, channel names and initial states.  The text
!> of the kinds written as equations (equations, sixdof, flight_path; the
!> longitudinal kind with tables) is made in mlid_deck_equations.
submodule (mlid_deck) mlid_deck_model
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_case, only: MAXSEG
  use mlid_models, only: model_t
  use mlid_model_factory, only: model_create, kind_code, MODEL_LINEAR, MODEL_AERO_LONG, MODEL_USER, &
                                MODEL_X22, MODEL_EQUATIONS
  use mlid_aero_long, only: aero_long_iconst, CONSTANT_NAMES
  use mlid_ties, only: tie_parse, MAXTERM
  use mlid_report, only: LABEL_WIDTH
  use mlid_params, only: no_ties
  use mlid_layout, only: layout_table_t, layout_table, layout_of, element_index, element_name, &
                         default_label, block_list
  use mlid_text, only: utf8_head
  implicit none

contains

  !> &model: the kind and sizes, the parameter vector, free parameters and
  !> their labels, ties, input hold and substeps, channel names.  Its lists
  !> are allocated (over half a megabyte of text and numbers: on the stack
  !> they overflowed a thread's 256 KB, and a shell's ulimit -s 512).
  module procedure read_model_group
    character(len=16) :: kind, input_hold
    integer :: nx, nu, ny, nw, substeps, ncoef(3), ios, nfree
    integer, allocatable :: user_iconst(:)
    real(wp), allocatable :: f(:), g(:), h(:), d(:), x0(:), bias(:), gamma(:), q(:), r(:), &
                             s(:), k(:), bx(:), cd(:), cl(:), cm(:), constants(:), p(:), &
                             user_rconst(:), initial_states(:), delay(:), udelay(:), stab(:), &
                             p0(:)
    character(len=8), allocatable :: cd_regressors(:), cl_regressors(:), cm_regressors(:)
    character(len=NAMELEN), allocatable :: free(:), names(:), state_names(:), input_names(:), &
                                           output_names(:)
    character(len=TIELEN), allocatable :: tie(:), xdot(:), outputs(:), definitions(:), params(:)
    character(len=TIELEN), allocatable :: xs(:)
    character(len=:), allocatable :: pre, post
    character(len=msg_len) :: iomsg
    integer, allocatable :: codes(:)
    real(wp), allocatable :: pstart(:), consts(:), urconst(:), x0s(:)
    integer :: niconst
    type(layout_table_t) :: lt
    type(options_t) :: defaults
    character(len=:), allocatable :: gtext
    namelist /model/ kind, nx, nu, ny, nw, f, g, h, d, gamma, k, bx, x0, bias, q, r, s, free, names, &
      tie, input_hold, substeps, state_names, input_names, output_names, cd_regressors, &
      cl_regressors, cm_regressors, cd, cl, cm, constants, p, user_iconst, user_rconst, &
      xdot, outputs, definitions, params, initial_states, delay, udelay, stab, p0

    allocate (f(MAXX*MAXX), g(MAXX*MAXU), h(MAXY*MAXX), d(MAXY*MAXU), x0(MAXX), bias(MAXY), &
              gamma(MAXX*MAXW), q(MAXW), r(MAXY), s(MAXW*MAXY), k(MAXU*MAXX), bx(MAXX), &
              cd(MAXR), cl(MAXR), cm(MAXR), constants(9), p(MAXFREE), user_rconst(MAXFREE), &
              user_iconst(MAXFREE), initial_states(MAXX*MAXSEG), delay(MAXY), udelay(MAXU), &
              stab(MAXX*MAXY), p0(MAXX), cd_regressors(MAXR), cl_regressors(MAXR), &
              cm_regressors(MAXR), free(MAXFREE), names(MAXFREE), state_names(MAXX), &
              input_names(MAXU), output_names(MAXY), tie(MAXFREE), xdot(MAXX), outputs(MAXY), &
              definitions(MAXDEF), params(MAXFREE), stat=ios)
    if (ios /= 0) then
      call fail(c, 'group &model: out of memory for its lists')
      return
    end if
    kind = 'linear'
    nx = 0
    nu = 0
    ny = 0
    nw = 0
    ! what a null value keeps (a block left out is zero; a required one is
    ! refused): which entries the deck gave is the scan's (element_states)
    f = 0.0_wp
    g = 0.0_wp
    h = 0.0_wp
    d = 0.0_wp
    gamma = 0.0_wp
    k = 0.0_wp
    bx = 0.0_wp
    x0 = 0.0_wp
    bias = 0.0_wp
    q = 0.0_wp
    r = 0.0_wp
    s = 0.0_wp
    cd = 0.0_wp
    cl = 0.0_wp
    cm = 0.0_wp
    constants = 0.0_wp
    p = 0.0_wp
    user_rconst = 0.0_wp
    user_iconst = 0
    cd_regressors = ''
    cl_regressors = ''
    cm_regressors = ''
    free = ''
    names = ''
    tie = ''
    state_names = ''
    input_names = ''
    output_names = ''
    input_hold = 'linear'
    substeps = defaults%substeps
    xdot = ''
    outputs = ''
    definitions = ''
    params = ''
    initial_states = 0.0_wp
    delay = 0.0_wp
    udelay = 0.0_wp
    stab = 0.0_wp
    p0 = 0.0_wp
    call at_most(rd, c, 'model', ['free ', 'names'], MAXFREE, 'free parameters')
    if (c%status /= MLID_OK) return
    gtext = group_text(rd, 'model')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=model, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'model', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    ! a word cut to its room could read as another ('linear' and more blanks)
    if (too_long(rd, c, 'model', ['kind      ', 'input_hold'], len(kind))) return
    if (too_long(rd, c, 'model', ['cd_regressors', 'cl_regressors', 'cm_regressors'], &
                 len(cd_regressors))) return
    ! free and names have no default: a null would drop a parameter unseen
    call list_length(rd, c, 'model', 'free', MAXFREE, .false., nfree)
    call list_length(rd, c, 'model', 'names', MAXFREE, .false., nfree)
    call take_list(rd, c, 'model', 'constants', constants, consts, .false.)
    call take_list(rd, c, 'model', 'user_rconst', user_rconst, urconst, .false.)
    call list_length(rd, c, 'model', 'user_iconst', size(user_iconst), .false., niconst)
    call take_list(rd, c, 'model', 'initial_states', initial_states, x0s, .false.)
    if (c%status /= MLID_OK) return
    if (written_as_equations(kind)) then
      if (any(element_states(rd%given, 'model', 'p', size(p)) /= ABSENT) .or. &
          size(urconst) > 0 .or. niconst > 0) then
        call fail(c, 'group &model: kind = '''//trim(kind)//''' takes its parameters in '// &
                  'params (''NAME = value''), not p, user_iconst or user_rconst')
        return
      end if
      select case (to_lower(kind))
      case ('sixdof')
        call sixdof_deck(c, consts, state_names, xdot, input_names, definitions, pre, post, xs)
        if (c%status /= MLID_OK) return
        call equations_text(c, state_names, xs, input_names, output_names, outputs, &
                            definitions, params, pstart, pre, post)
      case ('flight_path')
        call flightpath_deck(c, consts, state_names, xdot, input_names, output_names, &
                             outputs, definitions, params, pstart)
      case default
        call equations_text(c, state_names, xdot, input_names, output_names, outputs, &
                            definitions, params, pstart)
      end select
      if (c%status /= MLID_OK) return
    else if (any(len_trim(xdot) > 0) .or. any(len_trim(outputs) > 0) .or. &
             (to_lower(kind) /= 'longitudinal' .and. (any(len_trim(definitions) > 0) .or. &
                                                     any(len_trim(params) > 0)))) then
      call fail(c, 'group &model: xdot, outputs, definitions and params are for kind = '// &
                '''equations'', ''sixdof'' or ''flight_path'' (definitions and params also '// &
                'for ''longitudinal'': its tables), not '''//trim(kind)//'''')
      return
    end if
    call model_kind(c, kind, [cd_regressors, cl_regressors, cm_regressors], consts, &
                    user_iconst(1:niconst), urconst, nx, nu, ny, nw, ncoef, codes)
    if (c%status /= MLID_OK) return
    if (too_long(rd, c, 'model', ['state_names ', 'input_names ', 'output_names', &
                                  'free        ', 'names       '], NAMELEN)) return
    if (all(count(len_trim(state_names) > 0) /= [0, c%nx])) then
      call fail(c, 'group &model: state_names names every state (nx = '//itoa(c%nx)// &
                ') or none; given '//itoa(count(len_trim(state_names) > 0)))
      return
    end if
    if (c%mkind == MODEL_EQUATIONS) then             ! its parameters' own names, for free and tie
      call layout_of(c%mkind, nx, nu, ny, nw, c%iconst, c%rconst, lt, ios, iomsg)
      if (ios /= MLID_OK) then
        call fail(c, 'group &model: '//trim(iomsg))
        return
      end if
    else
      lt = layout_table(c%mkind, nx, nu, ny, nw, ncoef, codes)
    end if
    allocate (c%theta(lt%nth), c%isfree(lt%nth))
    c%tie = no_ties(lt%nth)
    c%isfree = 0
    if (c%mkind == MODEL_LINEAR) then
      call put_matrix(rd, c, lt, 'f', f, required=.true.)
      call put_matrix(rd, c, lt, 'g', g, required=nu > 0)
      call put_matrix(rd, c, lt, 'h', h, required=.true.)
      call put_matrix(rd, c, lt, 'd', d, required=.false.)
      call put_matrix(rd, c, lt, 'gamma', gamma, required=nw > 0)
      call put_matrix(rd, c, lt, 'k', k, required=.false.)
      call put_matrix(rd, c, lt, 'bx', bx, required=.false.)
    else if (c%mkind == MODEL_AERO_LONG) then
      call put_matrix(rd, c, lt, 'cd', cd, required=.false.)
      call put_matrix(rd, c, lt, 'cl', cl, required=.false.)
      call put_matrix(rd, c, lt, 'cm', cm, required=.false.)
    else if (c%mkind == MODEL_EQUATIONS) then
      c%theta(1:size(pstart)) = pstart
    else
      call put_matrix(rd, c, lt, 'p', p, required=ncoef(1) > 0)
    end if
    call put_matrix(rd, c, lt, 'x0', x0, required=.false.)
    call put_matrix(rd, c, lt, 'bias', bias, required=.false.)
    call put_matrix(rd, c, lt, 'q', q, required=.false.)
    call put_matrix(rd, c, lt, 'r', r, required=.false.)
    call put_matrix(rd, c, lt, 's', s, required=.false.)
    call put_matrix(rd, c, lt, 'delay', delay, required=.false.)
    call put_matrix(rd, c, lt, 'udelay', udelay, required=.false.)
    call put_matrix(rd, c, lt, 'stab', stab, required=.false.)
    call put_matrix(rd, c, lt, 'p0', p0, required=.false.)
    ! tables make it an equations model: free and tie name that model's parameters
    if (c%status == MLID_OK .and. c%mkind == MODEL_AERO_LONG .and. &
        (any(len_trim(definitions) > 0) .or. any(len_trim(params) > 0))) &
      call longitudinal_tables(c, lt, definitions, params)
    if (c%status == MLID_OK) call set_free(c, lt, free, names, free_idx)
    if (c%status == MLID_OK) call set_ties(c, lt, tie)
    if (c%status == MLID_OK) call set_option(c, 'group &model: ', 'input_hold', input_hold)
    if (c%status == MLID_OK) call set_option(c, 'group &model: ', 'substeps', itoa(substeps))
    c%input_names = pack(input_names, len_trim(input_names) > 0)
    c%output_names = pack(output_names, len_trim(output_names) > 0)
    if (all(size(c%input_names) /= [0, c%nu]) .or. all(size(c%output_names) /= [0, c%ny])) &
      call fail(c, 'group &model: input_names and output_names name every input and output '// &
                '(nu = '//itoa(c%nu)//', ny = '//itoa(c%ny)//') or none; given '// &
                itoa(size(c%input_names))//' and '//itoa(size(c%output_names)))
    c%initial_states = x0s
    if (size(c%initial_states) > 0 .and. (mod(size(c%initial_states), max(c%nx, 1)) /= 0 &
        .or. c%nx == 0)) call fail(c, 'group &model: initial_states needs nx = '// &
        itoa(c%nx)//' values per manoeuvre, got '//itoa(size(c%initial_states)))
  end procedure read_model_group

  !> The model kind and its sizes and constants (a built-in model's sizes
  !> are its own; nx, nu, ny, nw may be left out or must agree).
  subroutine model_kind(c, kind, regressors, constants, user_iconst, user_rconst, nx, nu, ny, &
                        nw, ncoef, codes)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: kind, regressors(:)
    real(wp), intent(in) :: constants(:), user_rconst(:)
    integer, intent(in) :: user_iconst(:)
    integer, intent(inout) :: nx, nu, ny, nw
    integer, intent(out) :: ncoef(3)
    integer, allocatable, intent(out) :: codes(:)
    character(len=msg_len) :: iomsg
    integer :: ios

    ncoef = 0
    allocate (codes(0), c%rconst(0))
    ! a model written as equations has its text in iconst already
    if (.not. written_as_equations(kind) .or. .not. allocated(c%iconst)) c%iconst = [integer ::]
    c%mkind = kind_code(to_lower(kind))
    if (written_as_equations(kind)) c%mkind = MODEL_EQUATIONS   ! sixdof, flight_path too
    select case (c%mkind)
    case (MODEL_LINEAR)
    case (MODEL_AERO_LONG)
      call aero_long_iconst(regressors(1:MAXR), regressors(MAXR + 1:2*MAXR), &
                            regressors(2*MAXR + 1:), codes, ios, iomsg)
      if (ios /= MLID_OK) then
        call fail(c, 'group &model: '//trim(iomsg))
        return
      end if
      ncoef = codes(1:3)
      codes = codes(4:)
      if (size(constants) /= 9) then
        call fail(c, 'group &model: constants needs 9 values: '//CONSTANT_NAMES)
        return
      end if
      c%iconst = [ncoef, codes]
      c%rconst = constants
    case (MODEL_USER)
      c%iconst = user_iconst
      c%rconst = user_rconst
    case (MODEL_X22, MODEL_EQUATIONS)
    case default
      call fail(c, 'group &model: unknown kind '''//trim(kind)//''' (available: linear, '// &
                'longitudinal, x22, user, equations, sixdof, flight_path)')
      return
    end select
    if (c%mkind /= MODEL_LINEAR) then
      call own_sizes(c, nx, nu, ny, nw, ncoef)
      if (c%status /= MLID_OK) return
    end if
    if (nx < merge(0, 1, c%mkind == MODEL_EQUATIONS) .or. nx > MAXX .or. nu < 0 .or. nu > MAXU .or. ny < 1 .or. ny > MAXY .or. &
        nw < 0 .or. nw > MAXW) then
      write (iomsg, '(a,4(1x,i0),a,4(1x,i0))') 'group &model: nx, nu, ny, nw =', nx, nu, ny, nw, &
        ' out of range; limits are', MAXX, MAXU, MAXY, MAXW
      call fail(c, iomsg)
      return
    end if
    c%nx = nx
    c%nu = nu
    c%ny = ny
    c%nw = nw
  end subroutine model_kind

  !> A built-in or user model's own sizes (from the model itself); sizes
  !> the deck gives must agree with them.
  subroutine own_sizes(c, nx, nu, ny, nw, ncoef)
    type(case_t), intent(inout) :: c
    integer, intent(inout) :: nx, nu, ny, nw, ncoef(3)
    class(model_t), allocatable :: m
    character(len=msg_len) :: iomsg
    integer :: ios

    call model_create(c%mkind, -1, -1, -1, -1, c%iconst, c%rconst, m, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(c, 'group &model: '//trim(iomsg))
      return
    end if
    if (c%mkind /= MODEL_USER .and. any([nx, nu, ny, nw] /= 0 .and. &
                                        [nx, nu, ny, nw] /= [m%nx, m%nu, m%ny, m%nw])) then
      write (iomsg, '(a,3(i0,a),i0)') 'group &model: this model has nx, nu, ny, nw = ', m%nx, &
        ', ', m%nu, ', ', m%ny, ', ', m%nw
      call fail(c, iomsg)
      return
    end if
    nx = m%nx
    nu = m%nu
    ny = m%ny
    nw = m%nw
    if (c%mkind /= MODEL_AERO_LONG) ncoef(1) = m%np
  end subroutine own_sizes

  !> Place block key of the deck (a matrix given row by row) into theta
  !> (column-major); a block not given is zero unless required.  A null
  !> value keeps its entry's default, zero: a required block has none.  A
  !> block that is not required may name some of its elements alone
  !> (x0(2) = 0.5): the others keep their default, as a null does.
  subroutine put_matrix(rd, c, lt, key, v, required)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    type(layout_table_t), intent(in) :: lt
    character(len=*), intent(in) :: key
    real(wp), intent(in) :: v(:)
    logical, intent(in) :: required
    character(len=msg_len) :: iomsg
    integer :: b, nr, nc, n, ngiven, i, j, o, st(size(v))

    if (c%status /= MLID_OK) return
    b = findloc(lt%key, key, 1)
    nr = lt%rows(b)
    nc = merge(1, lt%cols(b), lt%cols(b) < 0)
    n = nr*nc
    o = lt%off(b)
    st = element_states(rd%given, 'model', key, size(v))
    ngiven = count(st /= ABSENT)
    if (ngiven == 0 .and. .not. required) then
      c%theta(o + 1:o + n) = 0.0_wp
      return
    end if
    if (.not. required .and. by_index(rd, 'model', key)) then
      i = findloc(st /= ABSENT, .true., 1, back=.true.)
      if (i > n) then
        call fail(c, 'group &model: '//key//'('//itoa(i)//') is given, and '//key// &
                  ' takes '//trim(shape_text(nr, nc, lt%cols(b) < 0)))
        return
      end if
      where (st(1:n) == ABSENT) st(1:n) = NULLED      ! its default, as a null
      ngiven = n
    end if
    if (ngiven /= n .or. any(st(1:n) == ABSENT)) then
      if (lt%cols(b) < 0) then
        write (iomsg, '(a,i0,a,i0)') 'group &model: '//key//' has ', ngiven, &
          ' values, it needs ', n
      else
        write (iomsg, '(a,i0,a,i0,a,i0,a,i0,a)') 'group &model: '//key//' has ', ngiven, &
          ' values, '//key//' is ', nr, 'x', nc, ' and needs ', n, ' (row by row)'
      end if
      call fail(c, iomsg)
      return
    end if
    if (required .and. any(st(1:n) == NULLED)) then
      call fail(c, 'group &model: '//key//'('//itoa(findloc(st(1:n) == NULLED, .true., 1))// &
                ') is a null value, and '//key//' has no default to keep (it is needed)')
      return
    end if
    do i = 1, nr
      do j = 1, nc
        c%theta(o + (j - 1)*nr + i) = v((i - 1)*nc + j)
      end do
    end do
    if (.not. all(ieee_is_finite(c%theta(o + 1:o + n)))) &
      call fail(c, 'group &model: '//key//' has a value that is not finite')
  end subroutine put_matrix

  !> 'n values', or 'n values (nr x nc, row by row)'.
  function shape_text(nr, nc, vector) result(text)
    integer, intent(in) :: nr, nc
    logical, intent(in) :: vector
    character(len=:), allocatable :: text
    text = itoa(nr*nc)//' values'
    if (.not. vector) text = text//' ('//itoa(nr)//'x'//itoa(nc)//', row by row)'
  end function shape_text

  !> The free parameters (free_idx: their theta indices in the order of
  !> free) and their labels (names, else the default label).
  subroutine set_free(c, lt, free, names, free_idx)
    type(case_t), intent(inout) :: c
    type(layout_table_t), intent(in) :: lt
    character(len=*), intent(in) :: free(:), names(:)
    integer, allocatable, intent(out) :: free_idx(:)
    character(len=NAMELEN), allocatable :: labels(:)
    integer :: k, idx

    allocate (free_idx(0), labels(lt%nth))
    labels = ''
    do k = 1, size(free)
      if (len_trim(free(k)) == 0) cycle
      idx = element_index(lt, free(k))
      if (idx == 0) then
        call fail(c, 'group &model: free parameter '''//utf8_head(trim(free(k)), NAMELEN)// &
                  ''' does not exist ('//block_list(lt)//' within the dimensions)')
        return
      end if
      if (c%isfree(idx) > 0) then
        call fail(c, 'group &model: free parameter '''//trim(free(k))//''' listed twice')
        return
      end if
      c%isfree(idx) = size(free_idx) + 1           ! its place in the order of free
      free_idx = [free_idx, idx]
      labels(idx) = default_label(lt, idx)
      if (len_trim(names(k)) > 0) labels(idx) = names(k)
      if (len_trim(labels(idx)) > LABEL_WIDTH) then
        ! the report's column is LABEL_WIDTH bytes (UTF-8: one to four a character)
        call fail(c, 'group &model: the label '''//utf8_head(trim(labels(idx)), NAMELEN)// &
                  ''' of free parameter '//itoa(k)//' is longer than the '//itoa(LABEL_WIDTH)// &
                  ' bytes the report prints (a shorter one in names)')
        return
      end if
    end do
    if (count(len_trim(names) > 0) > size(free_idx)) then
      call fail(c, 'group &model: more names than free parameters')
      return
    else if (any(len_trim(names) > 0) .and. count(len_trim(names) > 0) < size(free_idx)) then
      call fail(c, 'group &model: names has '//itoa(count(len_trim(names) > 0))// &
                ' labels for '//itoa(size(free_idx))//' free parameters (one per free '// &
                'parameter, in the order of free, or none)')
      return
    end if
    c%labels = labels(free_idx)
  end subroutine set_free

  !> Ties 'a = b' or 'a = c + s*b + ...' (mlid_ties), each tied entry once.
  subroutine set_ties(c, lt, tie)
    type(case_t), intent(inout) :: c
    type(layout_table_t), intent(in) :: lt
    character(len=*), intent(in) :: tie(:)
    integer :: k, to, n, from(MAXTERM), status
    real(wp) :: offset, scale(MAXTERM)
    character(len=msg_len) :: msg
    do k = 1, size(tie)
      if (len_trim(tie(k)) == 0) cycle
      if (len_trim(tie(k)) == len(tie(k))) then       ! namelist input cuts what does not fit
        call fail(c, 'group &model: tie '''//utf8_head(tie(k), 40)//'...'' is longer than '// &
                  itoa(len(tie(k)) - 1)//' bytes')
        return
      end if
      call tie_parse(lt, tie(k), to, offset, n, from, scale, status, msg)
      if (status == MLID_OK .and. any(c%tie%to == to)) then
        status = MLID_ERR_INPUT
        msg = 'tie '''//trim(tie(k))//''': the parameter is tied twice'
      end if
      if (status /= MLID_OK) then
        call fail(c, 'group &model: '//trim(msg))
        return
      end if
      c%tie%to = [c%tie%to, spread(to, 1, n)]
      c%tie%from = [c%tie%from, from(1:n)]
      c%tie%scale = [c%tie%scale, scale(1:n)]
      c%tie%offset(to) = offset
    end do
    ! in the words mlid/model.py uses for a model built in Python
    do k = 1, size(c%tie%to)
      if (c%isfree(c%tie%to(k)) > 0) then
        call fail(c, 'group &model: parameter '''//trim(element_name(lt, c%tie%to(k)))// &
                  ''' is both free and tied')
        return
      else if (any(c%tie%to == c%tie%from(k))) then
        call fail(c, 'group &model: '''//trim(element_name(lt, c%tie%to(k)))//''' is tied to '''// &
                  trim(element_name(lt, c%tie%from(k)))//''', which is itself tied (a chain or '// &
                  'a cycle of ties): tie to the free parameter')
        return
      end if
    end do
  end subroutine set_ties

end submodule mlid_deck_model
