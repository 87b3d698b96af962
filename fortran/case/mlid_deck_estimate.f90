!> The reader of a deck's &estimate group (mlid_deck): the estimator's
!> options, the a priori values, weights and bounds per free parameter,
!> and the corrected records of a flight-path fit.
submodule (mlid_deck) mlid_deck_estimate
  use mlid_case, only: MAXSEG
  use mlid_options, only: option_get
  use mlid_initial_states, only: x0_rule_check
  use mlid_model_factory, only: model_create
  use mlid_models, only: model_t
  use mlid_equations, only: equations_smoothness
  use mlid_expr, only: split_definition
  implicit none

contains

  !> &estimate: the estimator's options, and a priori values, weights and
  !> bounds per free parameter (in the order of free).
  module procedure read_estimate_group
    character(len=32) :: noise, method, startup, rank_rule, process_noise, noise_criterion, &
                         filter_params, x0_from
    integer :: max_iter, halvings, rank_min, rank_max, ios, n_freq, x0_samples
    logical :: partials, steady_state
    real(wp) :: tol_cost, tol_step, tol_grad, rcond, prior_decay, f_min, f_max
    real(wp) :: prior(MAXFREE), prior_weight(MAXFREE), lower(MAXFREE), upper(MAXFREE)
    character(len=PATHLEN) :: corrected(MAXSEG)
    character(len=TIELEN) :: smoothness(MAXTABLES)
    character(len=msg_len) :: iomsg
    type(options_t) :: opt
    character(len=:), allocatable :: gtext
    namelist /estimate/ method, startup, max_iter, halvings, noise, partials, steady_state, &
      process_noise, noise_criterion, filter_params, tol_cost, tol_step, tol_grad, rcond, prior, &
      prior_weight, prior_decay, rank_min, rank_max, rank_rule, lower, upper, corrected, f_min, &
      f_max, n_freq, x0_from, x0_samples, smoothness

    call options_from_flat(c%iopt, c%ropt, opt, ios, iomsg)
    max_iter = opt%max_iter
    halvings = opt%halvings
    partials = opt%partials
    steady_state = opt%steady
    tol_cost = opt%tol_cost
    tol_step = opt%tol_step
    tol_grad = opt%tol_grad
    rcond = opt%rcond
    prior_decay = opt%prior_decay
    rank_min = opt%rank_min
    rank_max = opt%rank_max
    n_freq = opt%n_freq
    f_min = opt%f_min
    f_max = opt%f_max
    noise = option_get(c%iopt, c%ropt, 'noise')
    method = option_get(c%iopt, c%ropt, 'method')
    startup = option_get(c%iopt, c%ropt, 'startup')
    rank_rule = option_get(c%iopt, c%ropt, 'rank_rule')
    process_noise = option_get(c%iopt, c%ropt, 'process_noise')
    noise_criterion = option_get(c%iopt, c%ropt, 'noise_criterion')
    filter_params = option_get(c%iopt, c%ropt, 'filter_params')
    ! what an entry not given (or a null value) keeps: no a priori weight
    ! (its value the start value), no bound
    prior = 0.0_wp
    prior(1:size(free_idx)) = c%theta(free_idx)
    prior_weight = 0.0_wp
    lower = -huge(1.0_wp)
    upper = huge(1.0_wp)
    corrected = ''
    smoothness = ''
    x0_from = ''
    x0_samples = 0
    call at_most(rd, c, 'estimate', ['corrected'], MAXSEG, 'manoeuvres (data files)')
    call at_most(rd, c, 'estimate', ['smoothness'], MAXTABLES, 'tables')
    call at_most(rd, c, 'estimate', [character(len=12) :: 'prior', 'prior_weight', 'lower', &
                                     'upper'], MAXFREE, 'free parameters')
    if (c%status /= MLID_OK) return
    gtext = group_text(rd, 'estimate')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=estimate, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'estimate', ios, iomsg, .false., c)
    if (c%status /= MLID_OK) return
    if (too_long(rd, c, 'estimate', [character(len=16) :: 'method', 'startup', 'rank_rule', &
                 'noise', 'process_noise', 'noise_criterion', 'filter_params', 'x0_from'], &
                 len(method))) return
    call take_corrected(c, corrected)
    if (c%status == MLID_OK) call take_x0_from(c, x0_from, x0_samples)
    if (c%status /= MLID_OK) return
    opt%max_iter = max_iter
    opt%halvings = halvings
    opt%partials = partials
    opt%steady = steady_state
    opt%tol_cost = tol_cost
    opt%tol_step = tol_step
    opt%tol_grad = tol_grad
    opt%rcond = rcond
    opt%prior_decay = prior_decay
    opt%rank_min = rank_min
    opt%rank_max = rank_max
    opt%n_freq = n_freq
    opt%f_min = f_min
    opt%f_max = f_max
    call options_to_flat(opt, c%iopt, c%ropt)
    call set_option(c, 'group &estimate: ', 'method', method)
    call set_option(c, 'group &estimate: ', 'startup', startup)
    call set_option(c, 'group &estimate: ', 'rank_rule', rank_rule)
    call set_option(c, 'group &estimate: ', 'noise', noise)
    call set_option(c, 'group &estimate: ', 'process_noise', process_noise)
    call set_option(c, 'group &estimate: ', 'noise_criterion', noise_criterion)
    call set_option(c, 'group &estimate: ', 'filter_params', filter_params)
    if (c%status == MLID_OK) call put_extras(rd, c, free_idx, prior, prior_weight, lower, upper)
    if (c%status == MLID_OK) call take_smoothness(c, free_idx, smoothness)
  end procedure read_estimate_group

  !> &estimate x0_from, x0_samples: the measured states' x0 from each
  !> manoeuvre's record (mlid_initial_states), for the fits of estimate and
  !> validate.
  subroutine take_x0_from(c, x0_from, x0_samples)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: x0_from
    integer, intent(in) :: x0_samples
    character(len=msg_len) :: iomsg
    integer :: ios
    if (len_trim(x0_from) == 0) then
      if (x0_samples /= 0) call fail(c, 'group &estimate: x0_samples is for x0_from = ''mean''')
      return
    end if
    call x0_rule_check(x0_from, x0_samples, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(c, 'group &estimate: '//trim(iomsg))
    else if (c%job == 'monte_carlo') then
      call fail(c, 'group &estimate: x0_from is for the fits of estimate and validate cases '// &
                '(a Monte Carlo''s runs start from &model)')
    else
      c%x0_from = to_lower(x0_from)
      c%x0_samples = max(x0_samples, 1)
    end if
  end subroutine take_x0_from

  !> &estimate corrected: one record to write per data file, for a fit of
  !> kind 'flight_path' (the corrections it undoes are that kind's).
  subroutine take_corrected(c, corrected)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: corrected(:)
    character(len=msg_len) :: iomsg
    integer :: n
    if (all(len_trim(corrected) == 0)) return
    n = 0
    if (allocated(c%data_files)) n = size(c%data_files)
    if (.not. c%flight_path) then
      call fail(c, 'group &estimate: corrected writes the records with a flight-path fit''s '// &
                'corrections undone: it needs &model kind = ''flight_path''')
    else if (c%job /= 'estimate') then
      call fail(c, 'group &estimate: corrected is for job = ''estimate''')
    else if (any(len_trim(corrected(n + 1:)) > 0)) then
      write (iomsg, '(a,i0,a)') 'group &estimate: corrected names more files than the case''s ', &
        n, ' data files (one record written per data file, in their order)'
      call fail(c, iomsg)
    else if (any(len_trim(corrected(1:n)) == 0)) then
      write (iomsg, '(a,i0,a,i0,a)') 'group &estimate: corrected has no file for data file ', &
        findloc(len_trim(corrected(1:n)) == 0, .true., 1), ' (one record written per data '// &
        'file, in their order; the case has ', n, ')'
      call fail(c, iomsg)
    else
      c%corrected = corrected(1:n)
    end if
  end subroutine take_corrected

  !> A priori values and weights and bounds, given per free parameter in
  !> the order of free, into theta's order.  A list given whole (prior =
  !> ...) has one entry per free parameter, a null keeping its default; by
  !> element (lower(12:13) = ...) it gives those alone.
  subroutine put_extras(rd, c, free_idx, prior, prior_weight, lower, upper)
    type(reader_t), intent(in) :: rd
    type(case_t), intent(inout) :: c
    integer, intent(in) :: free_idx(:)
    real(wp), intent(in) :: prior(:), prior_weight(:), lower(:), upper(:)
    character(len=12), parameter :: KEYS(4) = [character(len=12) :: 'prior', 'prior_weight', &
                                               'lower', 'upper']
    integer :: j, nfr, k, m(4)

    nfr = size(free_idx)
    do k = 1, 4
      m(k) = last_element(rd%given, 'estimate', trim(KEYS(k)))
      j = whole_list_length(rd, 'estimate', trim(KEYS(k)))
      if (m(k) > nfr .or. (j >= 0 .and. j /= nfr)) then
        call fail(c, 'group &estimate: '//trim(KEYS(k))//' has '//itoa(max(m(k), j))// &
                  ' values; prior, prior_weight, lower and upper take one value per free '// &
                  'parameter ('//itoa(nfr)//', in the order of free; a null value keeps '// &
                  'its default), or name their elements: lower(2) = ...')
        return
      end if
    end do
    if (all(m == 0)) return
    call no_extras(c, nfr)
    do j = 1, nfr
      c%prior(free_idx(j)) = prior(j)
      c%pweight(j, j) = prior_weight(j)
      c%lower(free_idx(j)) = lower(j)
      c%upper(free_idx(j)) = upper(j)
    end do
    if (m(2) > 0) c%use_prior = 1
    if (m(3) + m(4) > 0) c%use_bounds = 1
  end subroutine put_extras

  !> The a priori values, weights and bounds of a case that gives none: the
  !> start values, no weight, no bounds (nfr free parameters).
  subroutine no_extras(c, nfr)
    type(case_t), intent(inout) :: c
    integer, intent(in) :: nfr
    allocate (c%prior(size(c%theta)), c%pweight(nfr, nfr), c%lower(size(c%theta)), &
              c%upper(size(c%theta)))
    c%prior = c%theta
    c%pweight = 0.0_wp
    c%lower = -huge(1.0_wp)
    c%upper = huge(1.0_wp)
  end subroutine no_extras

  !> &estimate smoothness = 'TABLE = lambda', ...: each table's smoothness
  !> prior (mlid_tables' table_smoothness; lambda = 1/sigma^2, sigma the a
  !> priori spread of one second difference) added into the a priori weight
  !> over the free values, about the prior values (by default the start).
  subroutine take_smoothness(c, free_idx, items)
    type(case_t), intent(inout) :: c
    integer, intent(in) :: free_idx(:)
    character(len=*), intent(in) :: items(:)
    class(model_t), allocatable :: m
    character(len=NAMELEN) :: names(size(items))
    character(len=:), allocatable :: rhs
    character(len=msg_len) :: iomsg
    real(wp) :: lambda(size(items))
    real(wp), allocatable :: w(:, :)
    integer :: k, n, ios, a, b

    n = 0
    do k = 1, size(items)
      if (len_trim(items(k)) == 0) cycle
      n = n + 1
      call split_definition(items(k), names(n), rhs, ios, iomsg)
      if (ios /= MLID_OK) then
        call fail(c, 'group &estimate: smoothness entry '''//trim(items(k))//''' is not '// &
                  '''TABLE = weight'': '//trim(iomsg))
        return
      end if
      call number_value(c, 'group &estimate: smoothness entry', items(k), rhs, lambda(n))
      if (c%status /= MLID_OK) return
    end do
    if (n == 0) return
    call model_create(c%mkind, -1, -1, -1, -1, c%iconst, c%rconst, m, ios, iomsg)
    if (ios == MLID_OK) then
      allocate (w(m%np, m%np), stat=ios)
      if (ios /= 0) iomsg = 'smoothness: no memory for the weight'
    end if
    if (ios == MLID_OK) call equations_smoothness(m, names(1:n), lambda(1:n), w, ios, iomsg)
    if (ios /= MLID_OK) then
      call fail(c, 'group &estimate: '//trim(iomsg))
      return
    end if
    if (.not. allocated(c%pweight)) call no_extras(c, size(free_idx))
    do b = 1, size(free_idx)            ! theta's first np entries are p
      do a = 1, size(free_idx)
        if (max(free_idx(a), free_idx(b)) <= m%np) &
          c%pweight(a, b) = c%pweight(a, b) + w(free_idx(a), free_idx(b))
      end do
    end do
    c%use_prior = 1
  end subroutine take_smoothness

  !> The items (values and nulls) of the last assignment of key in group
  !> without a subscript (the whole list); -1 when none.
  integer function whole_list_length(rd, group, key)
    type(reader_t), intent(in) :: rd
    character(len=*), intent(in) :: group, key
    integer :: k
    whole_list_length = -1
    do k = 1, size(rd%given)
      if (rd%given(k)%group == group .and. rd%given(k)%key == key .and. &
          len_trim(rd%given(k)%subscript) == 0) whole_list_length = rd%given(k)%n
    end do
  end function whole_list_length

end submodule mlid_deck_estimate
